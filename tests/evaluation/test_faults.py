"""The fault grid: every fault runs on the real twin and changes what the PD meets."""

from __future__ import annotations

import pytest

from sphere_env.evaluation.cells import rollout
from sphere_env.evaluation.faults import FAULTS, PRESSURES_KPA, SHELLS, fault_jobs

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
