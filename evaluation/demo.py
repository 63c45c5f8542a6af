"""`make demo`: the project's main job on its default configuration."""

from evaluation.ramp_descent import main

if __name__ == "__main__":
    main()
