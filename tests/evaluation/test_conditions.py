"""Faults and calibrations as conditions of an evaluation sweep: the flags parse and refuse bad names
with the flag named before anything runs; each condition really changes the env its episodes run
in; the results, the report and the demo's summary carry every condition."""

from __future__ import annotations

import json

import pytest

from sphere_env.evaluation.cells import _env
from sphere_env.evaluation.conditions import condition_rates, fault_curves
from sphere_env.evaluation.demo import controller_summary
from sphere_env.evaluation.evaluate import SweepSpec, evaluate, main
from sphere_env.evaluation.faults import FAULTS, GRADED_FAULTS

GRID = ["--pressure-kpa", "8.5", "--shell-models", "injected", "--seeds", "0", "--workers", "1", "--replay"]


@pytest.mark.parametrize(
    "argv, needles",
    [
        (["--faults", "latency_9"], ["faults[0]", "'latency_9'", "--faults", "latency_3", "all"]),
        (["--faults", "all", "latency_1"], ["faults", "'all'"]),
        (["--faults", "latency_1", "latency_1"], ["faults", "each fault once"]),
        (["--calibrations", "free_robots"], ["calibrations[0]", "'free_robots'", "--calibrations", "v0_linear"]),
        (["--calibrations", "assets/calibration/free_robot.yaml"], ["calibrations[0]", "shipped"]),
        (["--fault-seeds", "-1"], ["fault_seeds[0]", "-1"]),
        (["--env-kwargs", "{randomization: {steer_friction_scale: 1.5}}"], ["env_kwargs.randomization"]),
    ],
)
def test_bad_condition_flags_are_refused_before_anything_runs(tmp_path, capsys, argv, needles):
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as exc:
        main(["--controller", "zero", *GRID, *argv, "--out", str(out)])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    for n in needles:
        assert n in err, err
    assert not out.exists()


def test_the_flags_add_one_condition_per_fault_and_calibration():
    spec = SweepSpec(controllers=["zero", "pd"], faults=["all"], calibrations=["free_robot"], fault_seeds=[0])
    assert spec.faults == list(GRADED_FAULTS)
    jobs = spec.jobs()
    assert len(jobs) == spec.episodes()
    conditions = {j["condition"] for j in jobs}
    assert conditions == {"nominal", "calibration:free_robot", *(f"fault:{f}" for f in GRADED_FAULTS)}
    latency = [j for j in jobs if j["condition"] == "fault:latency_3"]
    assert len(latency) == 2 * 3 * 3 and {j["seed"] for j in latency} == {0}  # 2 controllers × 3 shells × 3 p
    assert all(j["randomization"] == {"action_latency_steps": 3} for j in latency)
    beyond = {j["pressure_kpa"] for j in jobs if j["condition"] == "fault:pressure_beyond_range"}
    assert beyond == set(FAULTS["pressure_beyond_range"].pressures_kpa)
    cal = [j for j in jobs if j["condition"] == "calibration:free_robot"]
    assert len(cal) == 2 * 27 and all(j["env_kwargs"]["calibration"] == "free_robot" for j in cal)
    assert all("randomization" not in j for j in jobs if j["condition"] == "nominal")
    only_pd = SweepSpec(controllers=["zero", "pd"], faults=["leak"], condition_controllers=["pd"])
    assert {j["controller"] for j in only_pd.jobs() if j["condition"] != "nominal"} == {"pd"}
    assert len(only_pd.jobs()) == only_pd.episodes() == 2 * 27 + 27
    with pytest.raises(ValueError, match=r"condition_controllers\[0\]' = 'ppo'"):
        SweepSpec(controllers=["zero"], faults=["leak"], condition_controllers=["ppo"])


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    """The PD on one injected-shell cell: nominal, under joint friction × 1.5 at the drive and under the
    free_robot calibration (three short episodes, the real twin)."""
    spec = SweepSpec(
        controllers=["pd"],
        pressures_kpa=[8.5],
        shell_models=["injected"],
        seeds=[0],
        faults=["friction_drive_150pct"],
        calibrations=["free_robot"],
    )
    out = tmp_path_factory.mktemp("conditions") / "out"
    return spec, out, evaluate(spec, out, workers=1, replays=[])


def test_each_condition_changes_the_env_its_episodes_run_in(sweep):
    spec, _, _ = sweep
    jobs = {j["condition"]: j for j in spec.jobs()}
    params = {}
    for name, job in jobs.items():
        _, info = _env(job).reset(seed=job["seed"], options={"pressure_kpa": job["pressure_kpa"]})
        params[name] = info["params"]
    assert params["nominal"]["drive_friction_scale"] == 1.0 and params["nominal"]["calibration"] == "default"
    assert params["fault:friction_drive_150pct"]["drive_friction_scale"] == 1.5
    assert params["fault:friction_drive_150pct"]["steer_friction_scale"] == 1.0
    assert params["calibration:free_robot"]["calibration"] == "free_robot"
    built = _env(jobs["calibration:free_robot"]).unwrapped.calibration
    assert built.raw["name"] == "roboball-free-robot" and built.omega_n_intercept == 2.17215


def test_the_results_report_and_demo_summary_carry_every_condition(sweep):
    spec, out, res = sweep
    rows = {r["condition"]: r for r in res["rows"]}
    assert set(rows) == {"nominal", "fault:friction_drive_150pct", "calibration:free_robot"}
    returns = {k: r["return"] for k, r in rows.items()}
    assert len(set(returns.values())) == 3, returns  # each condition ran another episode
    assert [a["episodes"] for a in res["agg_controller"]] == [1]  # the summary is the nominal grid's
    rates = res["conditions"]["pd"]
    assert rates["faults"]["friction_drive_150pct"]["episodes"] == 1
    assert rates["calibrations"]["free_robot"]["success_rate"] == float(rows["calibration:free_robot"]["is_success"])
    csv = (out / "episodes.csv").read_text().splitlines()
    assert "condition" in csv[0].split(",") and len(csv) == 4
    report = (out / "report.md").read_text()
    assert "## Success per condition" in report and "fault:friction_drive_150pct" in report
    assert (out / "plots" / "fault_curves.png").stat().st_size > 0
    curve = fault_curves(res["rows"])["friction_drive"]["pd"]
    assert [level for level, _, _ in curve] == [1.0, 1.5]
    summary = json.loads(json.dumps(controller_summary(res, spec.shell_models)))
    pd = summary["pd"]
    assert (
        pd["faults"]["friction_drive_150pct"]["success_rate"]
        == rates["faults"]["friction_drive_150pct"]["success_rate"]
    )
    assert pd["calibrations"]["free_robot"]["success_rate"] in (0.0, 1.0)
    assert pd["per_shell"]["injected"]["success_rate"] == float(rows["nominal"]["is_success"])


def test_condition_rates_leave_a_controller_without_conditions_empty():
    rows = [
        {"controller": "pd", "condition": "nominal", "is_success": True},
        {"controller": "pd", "condition": "fault:leak", "is_success": False},
        {"controller": "pd", "condition": "fault:leak", "is_success": True},
        {"controller": "zero", "condition": "nominal", "is_success": False},
    ]
    rates = condition_rates(rows)
    assert rates["pd"]["faults"]["leak"] == {"success_rate": 0.5, "episodes": 2}
    assert rates["zero"] == {"faults": {}, "calibrations": {}}


def test_a_fault_curve_compares_with_the_nominal_episodes_of_the_same_seeds():
    def row(condition, seed, success, pressure=8.5):
        return {
            "controller": "pd",
            "condition": condition,
            "seed": seed,
            "is_success": success,
            "pressure_kpa": pressure,
        }

    rows = [row("nominal", 0, True), row("nominal", 1, False), row("nominal", 2, False), row("nominal", 0, True, 3.0)]
    rows += [row("fault:latency_3", 0, False), row("fault:pressure_beyond_range", 0, True, 16.0)]
    curves = fault_curves(rows)
    assert curves["latency"]["pd"] == [(0.0, 1.0, 2), (3, 0.0, 1)]  # seeds 1 and 2 left out of the baseline
    assert curves["pressure"]["pd"] == [(3.0, 1.0, 1), (8.5, 1.0, 1), (16.0, 1.0, 1)]
    assert set(curves) == {"latency", "pressure"}
