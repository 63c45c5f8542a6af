"""k_d matching records the plant step it ran at (the calibration's fitted_time_step_s)."""

import logging

import pytest

from sphere_env.calibration.sensitivity import match_dissipation
from sphere_env.models.shell import ShellCalibration


@pytest.mark.slow
def test_match_dissipation_reports_the_step_it_ran_at(caplog):
    cal = ShellCalibration.load()
    p0 = cal.nominal_pressure_kpa
    with caplog.at_level(logging.WARNING):
        m = match_dissipation(None, p0, duration_s=3.0, xtol=0.05, time_step_s=0.004)
    assert m["time_step_s"] == 0.004
    assert m["zeta_sim"] == pytest.approx(m["target_zeta"], rel=0.05)
    # The twin warned that the 4 ms step differs from the calibration's: the decays really ran at 4 ms.
    assert cal.fitted_time_step_s == 0.005
    assert any("time_step_s=0.004 s differs" in r.getMessage() for r in caplog.records)
