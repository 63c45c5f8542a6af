"""Training entry points (stable-baselines3) for the sphere_env environments.

python -m training.train --env sphere_env/RampDescent-v2 --algo ppo
"""
