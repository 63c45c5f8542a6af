"""The shell calibration each episode's twin uses: the env's own (its ``calibration`` kwarg), or a
shipped one that a randomization of ``calibration`` drew, loaded on first use and kept."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

from sphere_env.models.calibration_files import calibration_name
from sphere_env.models.shell import ShellCalibration
from sphere_env.physics import Twin


class EpisodeCalibrations:
    """The calibrations of one environment, every one widened by the same pressure margin.

    :param calibration: the env's ``calibration`` kwarg (a path, a shipped name or None).
    :param extrapolation_kpa: the env's ``pressure_extrapolation_kpa``.
    :param where: what a refused calibration is named after (``"<task> kwargs"``).
    """

    def __init__(self, calibration: str | Path | None, extrapolation_kpa: float, where: str):
        try:
            self.own = ShellCalibration.load(calibration).extrapolated(extrapolation_kpa)
        except ValueError as err:
            raise ValueError(f"{where}: field 'calibration' = {calibration!r}: {err}") from None
        self.path = calibration
        #: how a parameter set names the env's own calibration (:func:`calibration_name`)
        self.own_name = calibration_name(calibration)
        self._extrapolation_kpa = extrapolation_kpa
        self._shipped: dict[str, ShellCalibration] = {}

    def named(self, name: str) -> ShellCalibration:
        """The calibration a parameter set names: the env's own, or a shipped one (loaded once)."""
        if name == self.own_name:
            return self.own
        cal = self._shipped.get(name)
        if cal is None:
            cal = self._shipped[name] = ShellCalibration.load(name).extrapolated(self._extrapolation_kpa)
        return cal

    def use(self, twin: Twin, params: Mapping[str, Any]) -> None:
        """Give ``twin`` the episode's calibration (``params["calibration"]``); no rebuild."""
        cal = self.named(params["calibration"])
        if twin.calibration.source != cal.source:
            twin.set_calibration(cal, params["pressure_kpa"])
