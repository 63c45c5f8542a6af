"""``train --resume RUN`` continues the run with the configuration in its ``config.yaml``: a flag it
would not apply (env, algorithm, hyperparameters, env kwargs, seeds, periods...) is refused by name
before the run folder is read or written, never accepted, ignored and recorded as if applied."""

from __future__ import annotations

import pytest

from sphere_env.training.train import main

CONFIG = "env_id: sphere_env/RampDescent-v3\nalgo: ppo\n"


@pytest.fixture
def run(tmp_path):
    folder = tmp_path / "run"
    folder.mkdir()
    (folder / "config.yaml").write_text(CONFIG)
    return folder


@pytest.mark.parametrize(
    "flags, named",
    [
        (["--env", "sphere_env/Roll-v1"], ["--env"]),
        (["--algo", "sac"], ["--algo"]),
        (["-params", "n_envs:4"], ["-params/--hyperparams/--params"]),
        (["--env-kwargs", "shell_model:'point'"], ["--env-kwargs"]),
        (["--seed", "3", "--eval-freq", "100"], ["--seed", "--eval-freq"]),
        (["--env", "sphere_env/RampDescent-v3", "-conf", "my.yml"], ["--env", "-conf/--conf-file"]),
    ],
    ids=["env", "algo", "params", "env-kwargs", "seed-and-eval-freq", "conf"],
)
def test_a_flag_a_resume_would_not_apply_is_refused_by_name(run, capsys, flags, named):
    with pytest.raises(SystemExit) as exc:
        main(["--resume", str(run), "-n", "64", *flags, "--no-progress"])
    err = capsys.readouterr().err.strip()
    assert exc.value.code == 2 and len(err.splitlines()) == 1
    assert "error: resume: " in err and all(name in err for name in named), err
    assert "takes -n/--n-timesteps, --no-progress and -v only" in err
    assert sorted(p.name for p in run.iterdir()) == ["config.yaml"]
    assert (run / "config.yaml").read_text() == CONFIG


def test_the_flags_a_resume_takes_pass_on_to_the_run_folder(run, capsys):
    """-n, --no-progress and -v are applied: the command goes on to read the run's config.yaml
    (here one naming an algorithm it does not train, refused as such)."""
    (run / "config.yaml").write_text(CONFIG.replace("ppo", "a2c"))
    with pytest.raises(SystemExit) as exc:
        main(["--resume", str(run), "-n", "64", "--no-progress", "-v", "0"])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and "error: resume:" not in err and "a2c" in err, err
