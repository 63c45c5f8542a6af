"""Calibration and validation against robot logs (issue 5).

``logs`` reads CSV logs and trial manifests into project state names and SI units; ``decay``
fits free decays and the pressure curves ω_n(p), ζ(p); ``friction_fit`` fits joint friction on
the ``stand`` fixture; ``shell_fit`` fits the shell models on steer-plane logs; ``sensitivity``
runs the hydroelastic sweep of paper Fig. 11; ``validate`` scores any log against any model.
CLI: ``python -m sphere_env.calibration --help``.
"""

from sphere_env.calibration.logs import ColumnMapping, LogError, Manifest, RobotLog, load_log, load_manifest

__all__ = ["ColumnMapping", "LogError", "Manifest", "RobotLog", "load_log", "load_manifest"]
