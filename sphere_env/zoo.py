"""rl-zoo3's entry into sphere_env: ``--gym-packages sphere_env.zoo`` registers the environments and
this project's policy names (``AsymmetricMlpPolicy``), so rl-zoo3 trains and tunes every section of
the shipped hyperparameter files as it is:

    python -m rl_zoo3.train --gym-packages sphere_env.zoo --env sphere_env/RampDescent-v3 --algo ppo \\
        -conf training/hyperparams/ppo.yml
"""

import sphere_env  # noqa: F401 - registers the environment ids
from sphere_env.training.policies import register

register()
