"""PME (eq. 12) against hand-computed values, sign convention, on-ramp only; episode metrics."""

from __future__ import annotations

import numpy as np
import pytest

from sphere_env.evaluation.metrics import episode_metrics, pme_between
from sphere_env.evaluation.sweep_report import pme_rows


def test_pme_hand_values_sign_and_on_ramp_only():
    t = np.array([0.0, 0.1, 0.2, 0.3])
    w_e = np.array([2.0, 4.0, 5.0, 10.0])
    w_s = np.array([1.0, 5.0, 5.0, 0.0])
    on = np.array([1, 1, 1, 0], bool)
    # (2-1)/2 = +0.5, (4-5)/4 = -0.25, 0 -> mean 0.25/3; the off-ramp sample (+100 %) is ignored
    assert pme_between(t, w_e, on, t, w_s) == pytest.approx(100 * 0.25 / 3)
    # the simulation underestimates everywhere -> positive; overestimates -> negative
    assert pme_between(t, w_e, np.ones(4, bool), t, 0.5 * w_e) == pytest.approx(50.0)
    assert pme_between(t, w_e, np.ones(4, bool), t, 1.2 * w_e) == pytest.approx(-20.0)
    # including the off-ramp sample changes the value: it really is excluded above
    assert pme_between(t, w_e, np.ones(4, bool), t, w_s) == pytest.approx(100 * 1.25 / 4)
    # the release (reference slower than the threshold) is left out too
    assert pme_between(t, np.array([0.1, 4.0, 5.0, 10.0]), on, t, w_s) == pytest.approx(100 * -0.25 / 2)


def test_pme_interpolates_simulation_onto_reference_times():
    t_e = np.array([0.0, 0.5, 1.0])
    w_e = np.array([1.0, 2.0, 4.0])
    t_s = np.array([0.0, 1.0])
    w_s = np.array([0.0, 2.0])  # at t_e: 0, 1, 2
    # samples: (1-0)/1 = 1, (2-1)/2 = 0.5, (4-2)/4 = 0.5 -> 2/3
    assert pme_between(t_e, w_e, np.ones(3, bool), t_s, w_s) == pytest.approx(100 * 2 / 3)


def test_pme_rows_pairs_models_in_both_directions():
    t = np.array([0.1, 0.2])
    mk = lambda w: {"t_s": t, "omega_d": np.array(w), "on_ramp": np.ones(2)}  # noqa: E731
    rows = [dict(controller="zero", shell_model=m, pressure_kpa=8.0, friction="majd", seed=0) for m in ("a", "b")]
    out = pme_rows(rows, [mk([2.0, 2.0]), mk([1.0, 1.0])])
    d = {(r["reference"], r["simulation"]): r["pme_percent"] for r in out}
    assert d[("a", "b")] == pytest.approx(50.0)  # b underestimates a
    assert d[("b", "a")] == pytest.approx(-100.0)  # a overestimates b


def test_episode_metrics_hand_values():
    tr = {
        "t_s": np.array([0.02, 0.04, 0.06]),
        "omega_d": np.array([1.0, 2.0, 3.0]),
        "omega_ref": np.array([2.0, 2.0, 2.0]),
        "x_m": np.zeros(3),
        "y_m": np.array([0.0, -0.3, 0.1]),
        "z_m": np.zeros(3),
        "tau_steer_nm": np.array([1.0, -2.0, 0.0]),
        "tau_drive_nm": np.array([0.0, 5.0, -10.0]),
        "theta_dot": np.array([2.0, 1.0, 0.0]),
        "drive_rate": np.array([0.0, -1.0, 0.5]),
        "on_ramp": np.array([1.0, 1.0, 0.0]),
        "reward": np.zeros(3),
    }
    m = episode_metrics(tr, 0.02)
    assert m["tracking_rmse_rad_s"] == pytest.approx(np.sqrt(0.5))  # errors -1, 0 on the ramp
    assert m["mean_omega_d_rad_s"] == pytest.approx(1.5)
    assert m["lateral_drift_m"] == pytest.approx(0.3)
    assert m["energy_j"] == pytest.approx((2 + 2 + 5 + 5) * 0.02)  # |1*2| + |-2*1| + |5*-1| + |-10*0.5|
    assert m["peak_torque_nm"] == pytest.approx(10.0)
    assert m["time_on_ramp_s"] == pytest.approx(0.04)
