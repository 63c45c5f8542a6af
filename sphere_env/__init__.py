"""sphere_env: a calibrated Drake digital twin and Gymnasium environments for soft,
pendulum-driven spherical robots (RoboBall).

Importing the package registers the Gymnasium environments (``sphere_env/...-v0``).
"""

__version__ = "0.1.0"
