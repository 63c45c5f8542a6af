"""Calibration and validation against robot logs.

``logs`` reads CSV logs and trial manifests (with time windows) into project state names and SI
units; ``events`` finds free-motion events in long logs; ``decay`` fits the pressure curves
ω_n(p), ζ(p) from free decays (the per-trial fit is :mod:`sphere_env.analysis.decay`);
``friction_fit`` fits joint friction on the ``stand`` fixture; ``shell_fit`` fits the shell
models; ``sensitivity`` runs the hydroelastic sweep of paper Fig. 11; ``validate`` scores any log
against any model; ``crossval`` fits on one segment and validates on the others; ``report``
writes the committed validation report. CLI: ``python -m sphere_env.calibration --help``.
"""

from sphere_env.calibration.log_csv import load_log
from sphere_env.calibration.logs import ColumnMapping, LogError, LogTrial, RobotLog
from sphere_env.calibration.manifest import Manifest, load_manifest

__all__ = ["ColumnMapping", "LogError", "LogTrial", "Manifest", "RobotLog", "load_log", "load_manifest"]
