"""The sphere-env command: dispatch to the modules' own parsers and the missing-extra message."""

from __future__ import annotations

import pytest

from sphere_env import cli


@pytest.mark.parametrize("name", sorted(cli.COMMANDS))
def test_subcommand_help_is_the_module_parser(name, capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main([name, "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith("usage:")
    if name != "calibrate":  # the calibration parser names its prog itself
        assert out.startswith(f"usage: sphere-env {name}")


def test_top_level_help_lists_every_subcommand(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    for name in ("train", "evaluate", "calibrate", "demo"):
        assert name in out


def test_unknown_subcommand_is_refused(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["fly"])
    assert exc.value.code == 2
    assert "invalid choice: 'fly'" in capsys.readouterr().err


def test_missing_extra_names_the_install_line(monkeypatch, capsys):
    needy = cli.Command(
        "sphere_env.evaluation.evaluate",
        "needs a package that is not installed",
        (("sphere_env_no_such_module", "train"), ("matplotlib", "eval")),
    )
    assert cli.missing_extras(needy) == ["train"]
    monkeypatch.setitem(cli.COMMANDS, "evaluate", needy)
    with pytest.raises(SystemExit) as exc:
        cli.main(["evaluate", "--controller", "zero"])
    assert exc.value.code == 2
    assert 'pip install "sphere_env[train]"' in capsys.readouterr().err


def test_arguments_reach_the_module_parser(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["train", "--algo", "dqn"])
    assert exc.value.code == 2
    assert "dqn" in capsys.readouterr().err


def test_train_takes_rl_zoo3_flags(capsys):
    with pytest.raises(SystemExit):
        cli.main(["train", "--help"])
    out = capsys.readouterr().out
    for flag in (
        "-conf",
        "--conf-file",
        "-params",
        "--hyperparams",
        "--env-kwargs",
        "--eval-env-kwargs",
        "-f",
        "--log-folder",
        "-i",
        "--trained-agent",
        "-tb",
        "--tensorboard-log",
        "--save-freq",
        "--eval-freq",
        "--eval-episodes",
        "-n",
        "--n-timesteps",
        "--seed",
        "--ray-address",
        "--seeds",
    ):
        assert f" {flag}" in out, flag


@pytest.mark.parametrize(
    "argv",
    [
        ["train", "--device", "banana"],
        ["evaluate", "--controller", "no_such_controller"],
        ["export", "/no/such/run"],
        ["enjoy", "/no/such/run"],
    ],
)
def test_errors_are_one_line_under_the_subcommands_name(capsys, argv):
    with pytest.raises(SystemExit) as exc:
        cli.main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"sphere-env {argv[0]}: error: "), err


@pytest.mark.parametrize(
    "module, argv, old",
    [
        ("sphere_env.evaluation.evaluate", ["--controller", "zero", "--pressures", "5"], "--pressures"),
        ("sphere_env.evaluation.enjoy", ["pretrained", "--pressure", "5"], "--pressure"),
        (
            "sphere_env.calibration.__main__",
            ["kd-pressure", "--time-step-s", "0.01", "--pressures-kpa", "3", "14", "--out", "x.yaml"],
            "--pressures-kpa",
        ),
        # a prefix of --pressure-kpa is not taken for it (argparse's abbreviations are off): named as renamed
        ("sphere_env.evaluation.evaluate", ["--controller", "zero", "--pressure", "5"], "--pressure"),
        ("sphere_env.calibration.__main__", ["sensitivity", "--pressure", "5"], "--pressure"),
        ("sphere_env.calibration.__main__", ["steer-fit", "--pressure", "5"], "--pressure"),
    ],
)
def test_former_pressure_spellings_fail_naming_the_new_one(module, argv, old, capsys):
    import importlib

    with pytest.raises(SystemExit) as exc:
        importlib.import_module(module).main(argv)
    assert exc.value.code == 2
    assert f"{old}: renamed; use --pressure-kpa" in capsys.readouterr().err


@pytest.mark.parametrize(
    "module, argv",
    [
        ("sphere_env.evaluation.evaluate", ["--controller", "zero", "--press", "5"]),
        ("sphere_env.training.train", ["--hyper", "n_envs:1"]),
        ("sphere_env.calibration.__main__", ["sensitivity", "--dur", "1"]),
    ],
)
def test_a_prefix_of_a_flag_is_refused(module, argv, capsys):
    import importlib

    with pytest.raises(SystemExit) as exc:
        importlib.import_module(module).main(argv)
    assert exc.value.code == 2
    assert "unrecognized arguments" in capsys.readouterr().err


@pytest.mark.parametrize(
    "items", [["{shell_model: point, randomization: 'off'}"], ["shell_model:'point'", "randomization:'off'"]]
)
def test_env_kwargs_read_the_same_in_every_subcommand(items):
    """One YAML mapping or rl-zoo3's key:value items: the same dict, by the one parser train,
    evaluate and enjoy use."""
    assert cli.parse_env_kwargs(items) == {"shell_model": "point", "randomization": "off"}


def test_env_kwargs_through_evaluate_and_train_command_lines(tmp_path):
    from sphere_env.training.train import build_parser

    args = build_parser().parse_args(["--env-kwargs", "{shell_model: point}"])
    assert args.env_kwargs == {"shell_model": "point"}
    args = build_parser().parse_args(["--env-kwargs", "shell_model:'point'", "incline_deg:6"])
    assert args.env_kwargs == {"shell_model": "point", "incline_deg": 6}
