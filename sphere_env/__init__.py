"""sphere_env: a calibrated Drake digital twin and Gymnasium environments for soft,
pendulum-driven spherical robots (RoboBall).

Importing the package registers the Gymnasium environments (``sphere_env/...-v0``).
Gymnasium 1.x no longer loads the ``gymnasium.envs`` entry-point group by itself; without an
import, ``gym.make("sphere_env:sphere_env/RampDescent-v0")`` imports this module first. The
entry point (``sphere_env:register_envs``) stays declared for tools and older Gymnasium (0.26–0.29)
that do load plugins.
"""

__version__ = "0.1.0"

#: id -> (entry point, max_episode_steps at the default 50 Hz control)
ENV_IDS = {
    "sphere_env/RampDescent-v0": ("sphere_env.envs.factories:make_ramp_descent", 400),
    "sphere_env/Roll-v0": ("sphere_env.envs.factories:make_roll", 500),
}


def register_envs() -> None:
    """Register the environments with Gymnasium (idempotent)."""
    from gymnasium.envs.registration import register, registry

    for env_id, (entry_point, steps) in ENV_IDS.items():
        if env_id not in registry:
            register(id=env_id, entry_point=entry_point, max_episode_steps=steps)


register_envs()
