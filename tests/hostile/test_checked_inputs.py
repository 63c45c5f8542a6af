"""Inputs that used to be barely checked, each refused by name with nothing written: a ``--pme-log``
with NaN, an impossible rate, an ``on_ramp`` other than 0/1 or no sample on the ramp; a robot log
with ``inf`` in a channel (the documented :class:`~sphere_env.calibration.logs.LogError`) or a
column name given twice; a hyperparameter file with a repeated key; a run folder's ``config.yaml``
with a top-level key the trainer never writes."""

from __future__ import annotations

import numpy as np
import pytest

from sphere_env.calibration.log_csv import load_log, write_log_csv
from sphere_env.calibration.logs import LogError
from sphere_env.evaluation.evaluate import main as evaluate_main
from sphere_env.evaluation.sweep_report import load_user_log
from sphere_env.resources import hyperparams_path, shipped_policy_path
from sphere_env.training.config import resolve_config
from sphere_env.training.run_folder import load_config

T = np.arange(101) * 0.02


def _pme_log(tmp_path, omega="1.0", on_ramp=None):
    rows = ["t_s,omega_d" + (",on_ramp" if on_ramp is not None else "")]
    for i in range(5):
        w = omega if i == 2 else "1.0"
        rows.append(f"{i * 0.02},{w}" + (f",{on_ramp if i == 2 else 1}" if on_ramp is not None else ""))
    path = tmp_path / "pme.csv"
    path.write_text("\n".join(rows) + "\n")
    return path


@pytest.mark.parametrize(
    "omega, on_ramp, needle",
    [
        ("nan", None, "line 4, column 'omega_d': nan rad/s; allowed: a finite rate with |omega_d| <= 500"),
        ("955", None, "line 4, column 'omega_d': 955.0 rad/s"),
        ("1.0", "2", "line 4, column 'on_ramp': 2; allowed: 0 or 1"),
        ("1.0", "yes", "line 4, column 'on_ramp': 'yes'; allowed: 0 or 1"),
    ],
    ids=["nan", "955-rad-s", "on_ramp-2", "on_ramp-text"],
)
def test_a_pme_log_with_an_impossible_value_is_refused(tmp_path, omega, on_ramp, needle):
    with pytest.raises(ValueError, match="pme_log: ") as err:
        load_user_log(_pme_log(tmp_path, omega, on_ramp))
    assert needle in str(err.value), str(err.value)


def test_a_pme_log_without_samples_on_the_ramp_is_refused_before_the_sweep(tmp_path, capsys):
    path = tmp_path / "off.csv"
    path.write_text("t_s,omega_d,on_ramp\n0,1,0\n0.02,1,0\n0.04,1,0\n")
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as exc:
        evaluate_main(["--controller", "zero", "--pme-log", str(path), "--out", str(out)])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and "has 0 samples with on_ramp = 1; at least 2" in err, err
    assert not out.exists()


def test_inf_in_the_yaw_channel_is_a_log_error(tmp_path):
    heading = 0.5 * np.sin(T)
    heading[40] = np.inf
    path = write_log_csv(tmp_path / "yaw.csv", T, {"theta": 0.1 * np.sin(T), "heading": heading})
    with pytest.raises(LogError, match=r"line 42, column 'shell_yaw.position': value inf is not finite"):
        load_log(path)


def test_a_column_name_given_twice_is_a_log_error(tmp_path):
    path = write_log_csv(tmp_path / "dup.csv", T, {"theta": 0.1 * np.sin(T)})
    lines = path.read_text().splitlines()
    lines = [f"{line},{line.split(',')[1]}" for line in lines]  # roll_joint.position again, with other values
    lines[1:] = [f"{line[: line.rindex(',')]},9" for line in lines[1:]]
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(LogError, match=r"header, column 3: the name 'roll_joint.position' is given twice"):
        load_log(path)


def test_a_hyperparameter_file_with_a_repeated_key_is_refused(tmp_path):
    text = hyperparams_path("ppo").read_text()
    env_line = next(line for line in text.splitlines() if line.startswith("sphere_env/RampDescent-v3"))
    path = tmp_path / "ppo.yml"
    path.write_text(text.replace(env_line, f"{env_line}\n  n_envs: 4\n  n_envs: 8", 1))
    with pytest.raises(ValueError, match=r"hyperparams: cannot read .*key 'n_envs' given twice"):
        resolve_config("sphere_env/RampDescent-v3", "ppo", path, build_env=False)


def test_a_run_config_with_an_unknown_top_level_key_is_refused(tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    text = (shipped_policy_path("pretrained") / "config.yaml").read_text()
    (run / "config.yaml").write_text(text + "learning_rat: 0.1\n")
    with pytest.raises(ValueError, match=r"config.yaml': unknown top-level key 'learning_rat'; allowed: the fields"):
        load_config(run)
    (run / "config.yaml").write_text(text)
    assert load_config(run).algo == "ppo"  # the keys the trainer writes, and those only
