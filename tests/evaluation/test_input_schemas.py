"""The evaluation tools' inputs load through typed schemas (sphere_env.evaluation.schemas): a wrong
type, an unknown key or a value out of range is refused on one line naming the field, with exit
code 2 on the command line, before anything runs or is written."""

from __future__ import annotations

import pytest

from sphere_env import cli
from sphere_env.evaluation.enjoy import EnjoySpec
from sphere_env.evaluation.evaluate import SweepSpec, evaluate
from sphere_env.evaluation.schemas import MAX_ENJOY_EPISODES, MAX_SEED, MAX_SWEEP_EPISODES, MAX_WORKERS, ControllerSpec
from sphere_env.schemas import validate

GRID = ["--pressure-kpa", "8.5", "--shell-models", "point", "--seeds", "0", "--workers", "1"]


def _one_line_refusal(capsys, argv, *needles):
    with pytest.raises(SystemExit) as exc:
        cli.main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"sphere-env {argv[0]}: error: "), err
    for n in needles:
        assert n in err[0], err[0]


@pytest.mark.parametrize(
    "argv, needles",
    [
        (["--controller", "zero", "--seeds", str(MAX_SEED + 1)], ["field 'seeds[0]' = 4294967296", "4294967295"]),
        (["--controller", "zero", "--workers", str(MAX_WORKERS + 1)], ["field 'workers' = 1025", "[1, 1024]"]),
        (["--controller", "zero", "--pressure-kpa", "nan"], ["field 'pressures_kpa[0]' = nan", "finite"]),
        (
            ["--controller", "zero", "--env", "sphere_env/Nope-v0"],
            ["field 'env_id' = 'sphere_env/Nope-v0'", "unknown env id"],
        ),
        (["--controller", "a=zero", "a=pd"], ["field 'controllers'", "labels must be unique"]),
        (["--controller", "=zero"], ["field 'controllers[0].label' = ''"]),
        (
            ["--controller", "no_such_controller"],
            ["field 'controllers[0].spec' = 'no_such_controller'", "module:function"],
        ),
        (["--controller", "zero", "--replay", "zero,point,8.5,0,1"], ["field 'replays[0]'", "5 parts"]),
        (["--controller", "zero", "--replay", "pd"], ["field 'replays[0].controller' = 'pd'", "['zero']"]),
        (["--controller", "zero", "--replay", "zero,jelly"], ["field 'replays[0].shell_model' = 'jelly'"]),
        (["--controller", "zero", "--replay", "zero,point,8.5,-3"], ["field 'replays[0].seed' = -3"]),
        (["--controller", "zero", "--pme-log-pressure-kpa", "inf"], ["field 'pme_log_pressure_kpa' = inf"]),
        (["--controller", "zero", "--ray-address", ""], ["field 'ray_address' = ''"]),
        (["--controller", "zero", "--env-kwargs", "{randomization: full}"], ["field 'env_kwargs.randomization'"]),
    ],
)
def test_evaluate_refuses_out_of_schema_options(tmp_path, capsys, argv, needles):
    _one_line_refusal(capsys, ["evaluate", *GRID, *argv, "--out", str(tmp_path / "o")], *needles)
    assert list(tmp_path.iterdir()) == []


def test_a_sweep_larger_than_the_bound_is_refused(tmp_path, capsys):
    seeds = [str(s) for s in range(MAX_SWEEP_EPISODES // 3 + 1)]
    _one_line_refusal(
        capsys,
        [
            "evaluate",
            "--controller",
            "zero",
            "--shell-models",
            "point",
            "injected",
            "hydroelastic",
            "--pressure-kpa",
            "8.5",
            "--seeds",
            *seeds,
            "--out",
            str(tmp_path / "o"),
        ],
        f"= 1 × 3 × 1 × 1 × {len(seeds)} = {3 * len(seeds)} episodes",
        f"at most {MAX_SWEEP_EPISODES}",
    )
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "argv, needles",
    [
        (["--episodes", str(MAX_ENJOY_EPISODES + 1)], ["field 'episodes' = 10001", "[1, 10000]"]),
        (["--seed", str(MAX_SEED + 1)], ["field 'seed' = 4294967296"]),
        (["--pressure-kpa", "nan"], ["field 'pressure_kpa' = nan"]),
        (["--realtime-rate", "-1"], ["field 'realtime_rate' = -1.0", ">= 0"]),
        (["--label", ""], ["field 'label' = ''"]),
        (["--env", "sphere_env/Nope-v0"], ["field 'env_id' = 'sphere_env/Nope-v0'", "unknown env id"]),
        (["--env-kwargs", "{meshcat: true}"], ["field 'env_kwargs.meshcat'", "--meshcat"]),
    ],
)
def test_enjoy_refuses_out_of_schema_options(tmp_path, capsys, argv, needles):
    _one_line_refusal(capsys, ["enjoy", "pretrained", *argv, "--video", str(tmp_path / "v")], *needles)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "argv, needles",
    [
        (["--tol", "nan"], ["field 'tol' = nan"]),
        (["--env", "sphere_env/Nope-v0"], ["field 'env_id' = 'sphere_env/Nope-v0'"]),
        (["--format", "ONNX"], ["field 'format' = 'ONNX'", "['onnx', 'torchscript']"]),
    ],
)
def test_export_refuses_out_of_schema_options(tmp_path, capsys, argv, needles):
    _one_line_refusal(capsys, ["export", "pretrained", *argv, "--out", str(tmp_path / "o")], *needles)
    assert list(tmp_path.iterdir()) == []


def test_the_python_interface_refuses_on_one_line_too(tmp_path):
    with pytest.raises(ValueError, match=r"^field 'seeds\[0\]' = -1: .*; allowed: "):
        SweepSpec(controllers=["zero"], seeds=[-1])
    with pytest.raises(ValueError, match=r"^unknown field 'pressures'; allowed: \[.*'pressures_kpa'"):
        SweepSpec(controllers=["zero"], pressures=[8.5])
    with pytest.raises(ValueError, match=r"^field 'episodes' = True"):
        EnjoySpec(run="pretrained", episodes=True)
    with pytest.raises(ValueError, match=r"^field 'workers' = 2.5"):
        evaluate(
            SweepSpec(controllers=["zero"], pressures_kpa=[8.5], shell_models=["point"], seeds=[0]),
            tmp_path / "o",
            workers=2.5,
        )
    assert list(tmp_path.iterdir()) == []


def test_a_controller_is_label_equals_spec_text_or_a_mapping():
    spec = SweepSpec(
        controllers=["zero", "brake=pd", {"label": "mine", "spec": "tests.evaluation.test_sweep:half_brake"}]
    )
    assert spec.labels == ["zero", "brake", "mine"]
    assert [str(c) for c in spec.controllers] == [
        "zero=zero",
        "brake=pd",
        "mine=tests.evaluation.test_sweep:half_brake",
    ]
    with pytest.raises(ValueError, match=r"^unknown field 'controllers\[0\]\.name'"):
        SweepSpec(controllers=[{"name": "z", "spec": "zero"}])
    with pytest.raises(ValueError, match=r"use <run>, <run>@best or <run>@<checkpoint steps>"):
        validate(ControllerSpec, {"label": "p", "spec": "pretrained@latest"})
