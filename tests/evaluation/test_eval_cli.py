"""Evaluation CLI: bad models, env kwargs, controllers and output folders are refused with a named
error before anything is written; a failing sweep leaves nothing behind; a reused output folder
holds only the latest sweep's files; a policy is evaluated only on the env id it was trained on."""

from __future__ import annotations

import numpy as np
import pytest

from sphere_env.cli import parse_env_kwargs
from sphere_env.evaluation.evaluate import SweepSpec, evaluate, main
from sphere_env.training.config import resolve_config
from sphere_env.training.trainer import train
from tests.conftest import TINY_PPO

GRID = [
    "--env",
    "sphere_env/RampDescent-v2",
    "--pressure-kpa",
    "8.5",
    "--shell-models",
    "point",
    "--seeds",
    "0",
    "--workers",
    "1",
    "--replay",
]


def three_actions(obs, info=None):
    """A controller returning the wrong shape."""
    return np.zeros(3)


class FailsLater:
    """A controller that acts once, then raises (a failure after validation)."""

    def __init__(self):
        self.calls = 0

    def __call__(self, obs, info=None):
        self.calls += 1
        if self.calls > 1:
            raise RuntimeError("controller broke mid-episode")
        return np.zeros(2)


def _refused(capsys, argv, *needles):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    for n in needles:
        assert n in err, err
    return err


@pytest.mark.parametrize(
    "text, needle",
    [
        ("{shell_model: point}", "env_kwargs.shell_model"),
        ("{randomization: full}", "env_kwargs.randomization"),
        ("{observation_noise_scale: 0.1, observation_noise_scale: 0.2}", "given twice"),
        ("{a: [1, 2", "not valid YAML"),
        ("[1, 2]", "must be a YAML mapping"),
        ("{no_such_kwarg: 1}", "no_such_kwarg"),
    ],
)
def test_bad_env_kwargs_refused(tmp_path, capsys, text, needle):
    _refused(capsys, ["--controller", "zero", "--env-kwargs", text, "--out", str(tmp_path / "o"), *GRID], needle)
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["--seeds", "-1"], "seeds"),
        (["--replay", "zero,point,99"], "field 'replays[0].pressure_kpa'"),
        (["--replay", "zero,point,x"], "replay"),
        (["--pme-reference", "jelly"], "pme_reference"),
        (["--workers", "0"], "workers"),
    ],
)
def test_bad_sweep_arguments_refused_before_the_sweep(tmp_path, capsys, argv, needle):
    _refused(capsys, ["--controller", "zero", "--out", str(tmp_path / "o"), *GRID, *argv], needle)
    assert not (tmp_path / "o").exists()


def test_parse_env_kwargs_accepts_a_mapping():
    assert parse_env_kwargs("{observation_noise_scale: 0.5}") == {"observation_noise_scale": 0.5}
    assert parse_env_kwargs("") == {}


def test_wrong_action_shape_refused(tmp_path, capsys):
    _refused(
        capsys,
        ["--controller", "tests.evaluation.test_eval_cli:three_actions", "--out", str(tmp_path / "o"), *GRID],
        "three_actions",
        "shape (3,)",
    )
    assert not (tmp_path / "o").exists()


def test_out_that_is_a_file_refused(tmp_path, capsys):
    f = tmp_path / "file"
    f.write_text("keep")
    _refused(capsys, ["--controller", "zero", "--out", str(f), *GRID], "field 'out'", "is a file")
    _refused(capsys, ["--controller", "zero", "--out", str(f / "sub"), *GRID], "field 'out'", "is a file")
    assert f.read_text() == "keep"


def test_truncated_model_refused(tiny_ppo_run, tmp_path, capsys):
    import shutil

    run = tmp_path / "run"
    shutil.copytree(tiny_ppo_run, run)
    data = (run / "model.zip").read_bytes()
    (run / "model.zip").write_bytes(data[: len(data) // 3])
    _refused(capsys, ["--controller", str(run), "--out", str(tmp_path / "o"), *GRID], "model.zip", "truncated")
    assert not (tmp_path / "o").exists()


def test_missing_vecnormalize_refused(tiny_ppo_run, tmp_path, capsys):
    import shutil

    run = tmp_path / "run"
    shutil.copytree(tiny_ppo_run, run)
    (run / "vecnormalize.json").unlink()
    _refused(capsys, ["--controller", str(run), "--out", str(tmp_path / "o"), *GRID], "vecnormalize.json", "is missing")
    assert not (tmp_path / "o").exists()


def test_policy_on_another_env_refused_unless_allowed(tiny_ppo_run, tmp_path, capsys):
    _refused(
        capsys,
        ["--controller", str(tiny_ppo_run), *GRID, "--env", "sphere_env/Roll-v1", "--out", str(tmp_path / "o")],
        "trained on 'sphere_env/RampDescent-v2'",
        "--allow-env-mismatch",
    )
    assert not (tmp_path / "o").exists()
    SweepSpec(
        controllers=[str(tiny_ppo_run)],
        env_id="sphere_env/RampDescent-v2",
        pressures_kpa=[8.5],
        shell_models=["point"],
        seeds=[0],
    ).check()


def test_failure_after_validation_leaves_nothing(tmp_path):
    spec = SweepSpec(
        controllers=["late=tests.evaluation.test_eval_cli:FailsLater"],
        pressures_kpa=[8.5],
        shell_models=["point"],
        seeds=[0],
    )
    with pytest.raises(RuntimeError, match="mid-episode"):
        evaluate(spec, tmp_path / "new" / "o", workers=1, replays=[])
    assert not (tmp_path / "new").exists()
    old = tmp_path / "old"
    old.mkdir()
    (old / "episodes.csv").write_text("earlier sweep")
    with pytest.raises(RuntimeError):
        evaluate(spec, old, workers=1, replays=[])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old"]  # no staging folder left
    assert [p.name for p in old.iterdir()] == ["episodes.csv"] and (old / "episodes.csv").read_text() == "earlier sweep"


def test_reused_out_holds_only_the_latest_sweep(tmp_path):
    out = tmp_path / "o"
    evaluate(
        SweepSpec(controllers=["zero"], pressures_kpa=[8.5], shell_models=["point", "injected"], seeds=[0]),
        out,
        workers=1,
        replays=[],
    )
    assert (out / "pme.csv").exists() and (out / "plots" / "pme.png").exists()
    (out / "notes.txt").write_text("mine")  # not the sweep's: kept
    earlier = out.stat().st_ino
    res = evaluate(
        SweepSpec(controllers=["pd"], pressures_kpa=[8.5], shell_models=["point"], seeds=[0]),
        out,
        workers=1,
        replays=[],
    )
    # the new set came in as one folder (a swap, never file by file), and nothing is left beside it
    assert out.stat().st_ino != earlier
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o"]
    assert not (out / "pme.csv").exists() and not (out / "plots" / "pme.png").exists()
    assert (out / "notes.txt").read_text() == "mine"
    assert all(p.exists() and p.is_relative_to(out) for p in res["files"].values())
    assert "pd" in (out / "episodes.csv").read_text() and "zero" not in (out / "episodes.csv").read_text()


def test_a_policy_with_its_own_observation_kwargs_is_evaluated_beside_the_baselines(tmp_path_factory):
    """A policy trained with ``observe_tracking_state`` (18 observations) is checked and run in an env
    built with its training kwargs, while the PD runs in the sweep's plain env (16)."""
    cfg = resolve_config(
        "sphere_env/RampDescent-v2",
        "ppo",
        overrides={
            **TINY_PPO,
            "n_timesteps": 32,
            "env_kwargs": {"shell_model": "point", "observe_tracking_state": True},
        },
        eval_episodes=1,
    )
    run = train(cfg, tmp_path_factory.mktemp("tracking") / "run", progress_bar=False)
    spec = SweepSpec(
        controllers=["pd", f"ppo={run}"],
        env_id="sphere_env/RampDescent-v2",
        pressures_kpa=[8.5],
        shell_models=["point"],
        seeds=[0],
    )
    spec.check()
    res = evaluate(spec, tmp_path_factory.mktemp("o") / "o", workers=1, replays=[])
    rows = {a["controller"]: a for a in res["agg_controller"]}
    assert rows["pd"]["episodes"] == rows["ppo"]["episodes"] == 1


def test_a_checkpoint_is_a_controller_spec(tiny_ppo_run):
    """``<run>@<steps>`` loads the checkpoint the trainer wrote at that step count (here the final
    one, which is the final model), and a step count without a checkpoint is refused by name."""
    import numpy as np

    from sphere_env.evaluation.controller_specs import PolicyController, check_spec, run_folder

    steps = sorted(int(p.stem.split("_")[-2]) for p in (tiny_ppo_run / "checkpoints").glob("rl_model_*_steps.zip"))[-1]
    check_spec(f"{tiny_ppo_run}@{steps}", "sphere_env/RampDescent-v2")
    ckpt, final = PolicyController(*run_folder(f"{tiny_ppo_run}@{steps}")), PolicyController(tiny_ppo_run)
    obs = np.random.default_rng(0).normal(size=(5, ckpt.model.observation_space.shape[0])).astype(np.float32)
    for o in obs:
        np.testing.assert_array_equal(ckpt.act(o), final.act(o))
    with pytest.raises(ValueError, match="is missing"):
        check_spec(f"{tiny_ppo_run}@999999", "sphere_env/RampDescent-v2")
    with pytest.raises(ValueError, match="<run>@<checkpoint steps>"):
        run_folder(f"{tiny_ppo_run}@latest")
