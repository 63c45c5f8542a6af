from sphere_env.evaluation.experiments.docs import main

raise SystemExit(main())
