"""The fault grids: every fault runs on the real twin and changes what the PD meets; the graded grid
holds the study grid and steps each family; explicit episode lists keep their seeds."""

from __future__ import annotations

import pytest

from sphere_env.evaluation.cells import _env, rollout
from sphere_env.evaluation.faults import (
    FAMILIES,
    FAULTS,
    GRADED_FAULTS,
    PRESSURES_KPA,
    SHELLS,
    episode_jobs,
    fault_episode_jobs,
    fault_jobs,
    grid_jobs,
)

ENV = "sphere_env/RampDescent-v3"


def test_each_fault_is_the_whole_grid():
    for name, fault in FAULTS.items():
        jobs = fault_jobs(name, "pd", "pd", ENV, {"observe_tracking_state": True})
        assert len(jobs) == len(SHELLS) * 3 * 3
        assert {j["pressure_kpa"] for j in jobs} == set(fault.pressures_kpa or PRESSURES_KPA)
        assert all(j["randomization"] == dict(fault.randomization) for j in jobs)
        assert all(j["env_kwargs"]["observe_tracking_state"] for j in jobs)  # the controller's kwargs kept


@pytest.mark.parametrize("name", sorted(FAULTS))
def test_every_fault_changes_the_pd_episode(name):
    """One PD episode (injected shell, seed 0) under the fault differs from the nominal one, and
    the episode's parameters record the fault."""
    fault = FAULTS[name]
    p = (fault.pressures_kpa or (8.5,))[0]
    job = fault_jobs(name, "pd", "pd", ENV, {}, shells=("injected",), seeds=(0,))
    job = next(j for j in job if j["pressure_kpa"] == p)
    nominal = dict(job, randomization="off", env_kwargs={}, pressure_kpa=min(max(p, 3.0), 14.0))
    row_f, tr_f = rollout(job)
    row_n, tr_n = rollout(nominal)
    assert row_f["return"] != row_n["return"]
    assert not row_f["truncated"] or not row_f["truncation_reason"].startswith("physics_failure")
    if name == "torque_saturation":
        assert max(abs(tr_f["tau_drive_nm"])) <= 0.6 * 22.0 + 1e-9 < max(abs(tr_n["tau_drive_nm"]))


def test_the_graded_grid_holds_the_study_grid_and_steps_each_family():
    assert all(GRADED_FAULTS[name] is fault for name, fault in FAULTS.items())  # one record per fault
    levels: dict[str, set] = {}
    for fault in GRADED_FAULTS.values():
        assert fault.family in FAMILIES and fault.why
        levels.setdefault(fault.family, set()).add(fault.level)
    for joint in ("steer", "drive", "both"):
        assert levels[f"friction_{joint}"] == {0.5, 0.75, 1.25, 1.5}
    assert levels["latency"] == {1, 2, 3}
    assert levels["payload"] == {1.0, 2.0, 3.0, 4.0}
    assert levels["pressure"] == {None}
    assert {"leak", "sensor_noise", "torque_saturation"} <= set(levels)


def test_explicit_episodes_keep_their_seeds_and_a_pressure_fault_its_pressures():
    episodes = [("point", 3.0, 100), ("injected", 5.2, 207), ("hydroelastic", 14.0, 311), ("injected", 9.0, 412)]
    jobs = episode_jobs("pd", "pd", ENV, {}, episodes)
    assert [(j["shell_model"], j["pressure_kpa"], j["seed"]) for j in jobs] == episodes
    assert "randomization" not in jobs[0]
    grid = grid_jobs("pd", "pd", ENV, {}, ("point",), (3.0, 8.5), (0, 1))
    assert grid == episode_jobs("pd", "pd", ENV, {}, [("point", p, s) for p in (3.0, 8.5) for s in (0, 1)])
    beyond = fault_episode_jobs("pressure_beyond_range", "pd", "pd", ENV, {}, episodes)
    assert [j["pressure_kpa"] for j in beyond] == [1.5, 16.0, 17.5, 1.5]
    assert [(j["shell_model"], j["seed"]) for j in beyond] == [(m, s) for m, _, s in episodes]
    assert all(j["env_kwargs"]["pressure_extrapolation_kpa"] == 3.5 for j in beyond)
    latency = fault_episode_jobs("latency_3", "pd", "pd", ENV, {"observe_pressure": True}, episodes)
    assert [j["pressure_kpa"] for j in latency] == [p for _, p, _ in episodes]
    assert all(
        j["randomization"] == {"action_latency_steps": 3} and j["env_kwargs"]["observe_pressure"] for j in latency
    )
    with pytest.raises(ValueError, match="unknown fault 'latency_9'; allowed"):
        fault_episode_jobs("latency_9", "pd", "pd", ENV, {}, episodes)


@pytest.mark.parametrize("name", sorted(set(GRADED_FAULTS) - set(FAULTS)))
def test_every_graded_fault_reaches_the_episode_parameters(name):
    """The env the evaluation builds for a graded fault's job reports the fault's values in
    ``info["params"]`` at reset (its events really set)."""
    fault = GRADED_FAULTS[name]
    job = fault_jobs(name, "pd", "pd", ENV, {}, shells=("injected",), seeds=(0,))[0]
    _, info = _env(job).reset(seed=0, options={"pressure_kpa": job["pressure_kpa"]})
    for param, value in fault.randomization.items():
        assert info["params"][param] == value, (param, info["params"][param])
