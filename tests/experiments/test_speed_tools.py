"""The pure parts of the speed and contact-solver studies: sorting perf samples into the pieces of a
step, and comparing two ω_d trajectories."""

import math

import numpy as np
import pytest

from sphere_env.evaluation.experiments.contact_solver import APART_RAD_S, CONTROL_PERIOD_S, compare_traces
from sphere_env.evaluation.experiments.profile_twin import sort_samples

ADVANCE = "drake::systems::Simulator<double>::AdvanceTo"
PY = "_PyEval_EvalFrameDefault"


def script(*stacks):
    """``perf script -F comm,ip,sym`` text of the given stacks (leaf first)."""
    out = []
    for frames in stacks:
        out.append("python ")
        out += [f"\t{1000 + i:x} {f}" for i, f in enumerate(frames)]
        out.append("")
    return "\n".join(out)


def test_samples_go_to_the_first_matching_piece():
    text = script(
        # the shell law evaluated inside the free-motion dynamics counts as the force systems
        [
            "drake::symbolic::Expression::Evaluate",
            "drake::systems::SymbolicVectorSystem<double>::CalcOutput",
            "drake::multibody::internal::SapDriver<double>::CalcFreeMotionVelocities",
            ADVANCE,
            PY,
        ],
        ["drake::multibody::contact_solvers::internal::SapSolver<double>::SolveWithGuess", ADVANCE, PY],
        [
            "malloc",
            "drake::multibody::contact_solvers::internal::SapModel<double>::MakeContext",
            "drake::multibody::contact_solvers::internal::SapSolver<double>::SolveWithGuess",
            ADVANCE,
            PY,
        ],
        ["drake::geometry::internal::ProximityEngine<double>::ComputePointPairPenetration", ADVANCE, PY],
        ["drake::systems::Context<double>::SetTime", ADVANCE, PY],
        ["PyFloat_FromDouble", PY],  # Twin.state()
        ["[unknown]", "[unknown]"],  # not unwound
    )
    out = sort_samples(text)
    assert out["samples"] == 7
    pct = out["pct"]
    share = 100.0 / 7
    assert pct["force_systems"] == pytest.approx(share)
    assert pct["contact_solve"] == pytest.approx(2 * share)
    assert pct["geometry"] == pytest.approx(share)
    assert pct["simulator"] == pytest.approx(share)
    assert pct["python"] == pytest.approx(share)
    assert pct["unresolved"] == pytest.approx(share)
    assert pct["free_motion"] == 0.0
    assert out["sap_context_pct"] == pytest.approx(share)
    assert sum(pct.values()) == pytest.approx(100.0)


def test_no_samples_is_said():
    assert sort_samples("") == {"samples": 0}


def test_trajectory_comparison_over_the_common_samples():
    ref = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    fast = np.array([0.0, 1.0, 2.1, 3.3])  # one step shorter, apart from the third sample on
    out = compare_traces(ref, fast)
    assert out["compared_samples"] == 4
    assert out["max_abs_diff_rad_s"] == pytest.approx(0.3)
    assert out["rmse_rad_s"] == pytest.approx(math.sqrt((0.1**2 + 0.3**2) / 4))
    assert 0.1 > APART_RAD_S
    assert out["apart_after_s"] == pytest.approx(3 * CONTROL_PERIOD_S)
    assert out["peak_rad_s"] == 4.0
    assert math.isnan(compare_traces(ref, ref)["apart_after_s"])
