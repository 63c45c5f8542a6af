"""Hostile inputs through the public entry points, one pytest case each: ``sphere-env train``,
``sphere-env evaluate`` and ``sphere-env calibrate`` command lines, calibration files and robot logs.

A command line is refused with exit code 2 and a single ``error:`` line naming the field (no
traceback); a calibration file with a ``ValueError`` naming it. Each case points its outputs into
a fresh empty folder, which must still be empty after the refusal. Slow: the command lines import
the training and evaluation stacks, and a few cases need a tiny trained run.
"""

from __future__ import annotations

import os
import shutil
import sys

import gymnasium as gym
import numpy as np
import pytest
import yaml

from sphere_env.cli import main as sphere_env_cli
from sphere_env.models.shell import ShellCalibration
from sphere_env.resources import asset_path
from tests.conftest import TINY_PPO_PARAMS

pytestmark = pytest.mark.slow

# Placeholders in the argv below, replaced by the prepared files of the ``inputs`` fixture.
INPUTS, RUN, TRUNCATED_RUN = "{inputs}", "{run}", "{truncated_run}"
UNWRITABLE, OUT = "{unwritable}", "{out}"
#: The env of the shared tiny PPO run (``tiny_ppo_run`` in ``tests/conftest.py``), which ``runs`` copies.
RUN_ENV = "sphere_env/RampDescent-v2"


def bad_shape_controller(obs, info=None):
    """A user controller returning three numbers instead of two (``--controller module:function``)."""
    return np.zeros(3)


# ---- sphere-env train: (id, argv, field) -------------------------------------------------------------
# Each runs with a tiny budget on the point shell (--params last: its values follow the tiny PPO ones).
TINY = ["--n-timesteps", "10", "--no-progress", "--env-kwargs", "shell_model:'point'"]
TRAIN = [
    ("ent_coef-not-a-number", ["--params", "ent_coef:abc"], "hyperparams.ent_coef"),
    ("n_epochs-zero", ["--params", "n_epochs:0"], "hyperparams.n_epochs"),
    ("gamma-2", ["--params", "gamma:2.0"], "hyperparams.gamma"),
    ("gae_lambda-negative", ["--params", "gae_lambda:-0.5"], "hyperparams.gae_lambda"),
    ("learning_rate-zero", ["--params", "learning_rate:0"], "hyperparams.learning_rate"),
    ("learning_rate-bad-schedule", ["--params", "learning_rate:lin_x"], "hyperparams.learning_rate"),
    ("clip_range-negative", ["--params", "clip_range:-0.2"], "hyperparams.clip_range"),
    ("max_grad_norm-zero", ["--params", "max_grad_norm:0"], "hyperparams.max_grad_norm"),
    ("batch_size-zero", ["--params", "batch_size:0"], "hyperparams.batch_size"),
    ("n_steps-float", ["--params", "n_steps:1.5"], "hyperparams.n_steps"),
    ("vf_coef-nan", ["--params", "vf_coef:.nan"], "hyperparams.vf_coef"),
    ("policy_kwargs-int", ["--params", "policy_kwargs:5"], "hyperparams.policy_kwargs"),
    ("unknown-hyperparameter", ["--params", "learning_rat:1e-3"], "hyperparams.learning_rat"),
    ("n_envs-zero", ["--params", "n_envs:0"], "n_envs"),
    ("n_envs-string", ["--params", "n_envs:abc"], "n_envs"),
    ("params-without-colon", ["--params", "noequals"], "params"),
    (
        "env_kwargs-pressure-range-reversed",
        ["--env-kwargs", "randomization:{'pressure_kpa': [14, 3]}"],
        "env_kwargs.randomization.pressure_kpa",
    ),
    (
        "env_kwargs-pressure-schedule-reversed",
        [
            "--env-kwargs",
            "randomization:{'pressure_kpa': {'distribution': 'uniform'}, "
            "'pressure_schedule': {'rate_kpa_per_s': [0.5, -0.5]}}",
        ],
        "env_kwargs.randomization",
    ),
    (
        "randomization-as-hyperparameter",
        ["--params", "randomization:'off'"],
        "hyperparams.randomization': a top-level key",
    ),
    ("env_kwargs-list", ["--params", "env_kwargs:[1, 2]"], "env_kwargs"),
    ("env_kwargs-unknown-shell", ["--env-kwargs", "shell_model:'jelly'"], "shell_model"),
    ("env_kwargs-not-a-literal", ["--params", "env_kwargs:{shell_model: jelly}"], "hyperparams.env_kwargs"),
    ("normalize-unknown-key", ["--params", "normalize:{'norm_ob': True}"], "normalize.norm_ob"),
    ("algo-unknown", ["--algo", "dqn"], "algo"),
    ("env-unknown", ["--env", "sphere_env/Nope-v0"], "env"),
    ("n_timesteps-zero", ["--n-timesteps", "0"], "n_timesteps"),
    ("n_timesteps-nan", ["--n-timesteps", "nan"], "n_timesteps"),
    ("eval_episodes-zero", ["--eval-episodes", "0"], "eval_episodes"),
    ("save_freq-string", ["--save-freq", "x"], "--save-freq"),
    ("torch_threads-zero", ["--torch-threads", "0"], "torch_threads"),
    ("seed-string", ["--seed", "x"], "--seed"),
    ("eval_pressures_kpa-below-range", ["--eval-pressures-kpa", "2"], "eval_pressures_kpa"),
    ("trained_agent-missing", ["-i", "missing.zip"], "trained_agent"),
    ("sac-ent_coef-negative-auto", ["--algo", "sac", "--params", "ent_coef:auto_-1"], "hyperparams.ent_coef"),
    ("sac-train_freq-not-a-literal", ["--algo", "sac", "--params", "train_freq:[1, hour]"], "hyperparams.train_freq"),
    ("sac-tau-zero", ["--algo", "sac", "--params", "tau:0"], "hyperparams.tau"),
]
# --resume of a folder that is not a readable run: (id, folder, field)
TRAIN_RESUME = [
    ("unreadable-config", f"{INPUTS}/bad_yaml_run", "config.yaml"),
    ("no-config", f"{INPUTS}/not_a_run", "config.yaml"),
]

# ---- sphere-env evaluate: (id, argv, field); a small replay grid around each -------------------------
GRID = ["--replay", "--pressure-kpa", "8.5", "--shell-models", "point", "--seeds", "0", "--workers", "1"]
EVALUATE = [
    ("controller-truncated-model", ["--controller", TRUNCATED_RUN, "--env", RUN_ENV], "model.zip"),
    (
        "env_kwargs-shell_model",
        ["--controller", "zero", "--env-kwargs", "{shell_model: point}"],
        "env_kwargs.shell_model",
    ),
    ("env_kwargs-duplicate-key", ["--controller", "zero", "--env-kwargs", "{a: 1, a: 2}"], "env_kwargs"),
    ("env_kwargs-malformed-yaml", ["--controller", "zero", "--env-kwargs", "{a: [1"], "env_kwargs"),
    ("env_kwargs-list", ["--controller", "zero", "--env-kwargs", "[1, 2]"], "env_kwargs"),
    ("env_kwargs-unknown", ["--controller", "zero", "--env-kwargs", "{no_such_kwarg: 1}"], "no_such_kwarg"),
    ("controller-wrong-action-shape", ["--controller", f"{__name__}:bad_shape_controller"], "shape"),
    ("controller-missing-module", ["--controller", "no_such_module:f"], "controller"),
    ("controller-trained-on-another-env", ["--controller", RUN, "--env", "sphere_env/Roll-v0"], "--allow-env-mismatch"),
    ("pressure_kpa-1000", ["--controller", "zero", "--pressure-kpa", "1000"], "pressure"),
    ("shell_models-unknown", ["--controller", "zero", "--shell-models", "jelly"], "shell_models"),
    ("friction-unknown", ["--controller", "zero", "--friction", "bogus"], "friction"),
    ("pme_log-missing", ["--controller", "zero", "--pme-log", f"{INPUTS}/missing.csv"], "pme_log"),
    ("pme_log-one-row", ["--controller", "zero", "--pme-log", f"{INPUTS}/one_row_pme.csv"], "pme_log"),
    ("seeds-negative", ["--controller", "zero", "--seeds", "-1"], "seeds"),
    ("replay-pressure-99", ["--controller", "zero", "--replay", "zero,point,99"], "replay"),
    ("pme_reference-unknown", ["--controller", "zero", "--pme-reference", "jelly"], "pme_reference"),
    ("workers-zero", ["--controller", "zero", "--workers", "0"], "workers"),
    ("out-is-a-file", ["--controller", "zero", "--out", f"{INPUTS}/a_file.txt"], "out"),
    ("faults-unknown", ["--controller", "zero", "--faults", "latency_9"], "--faults"),
    ("faults-all-and-another", ["--controller", "zero", "--faults", "all", "leak"], "faults"),
    ("faults-empty", ["--controller", "zero", "--faults"], "--faults"),
    ("calibrations-unknown", ["--controller", "zero", "--calibrations", "free_robots"], "--calibrations"),
    ("calibrations-a-path", ["--controller", "zero", "--calibrations", f"{INPUTS}/a_file.txt"], "--calibrations"),
    ("fault_seeds-negative", ["--controller", "zero", "--faults", "leak", "--fault-seeds", "-1"], "fault_seeds"),
]

# ---- sphere-env calibrate: (id, argv, field) ---------------------------------------------------------
VALIDATE = ["--models", "point", "--drive-friction", "none"]
GOOD = f"{INPUTS}/manifest_good.yaml"
CALIBRATE = [
    ("validate-tol-unknown-name", ["validate", "--manifest", GOOD, *VALIDATE, "--tol", "bogus=1"], "bogus"),
    ("validate-tol-not-a-number", ["validate", "--manifest", GOOD, *VALIDATE, "--tol", "theta=abc"], "theta"),
    ("validate-workers-zero", ["validate", "--manifest", GOOD, *VALIDATE, "--workers", "0"], "workers"),
    ("validate-manifest-missing", ["validate", "--manifest", f"{INPUTS}/missing.yaml", *VALIDATE], "manifest"),
    (
        "validate-trial-pressure-in-pa",
        ["validate", "--manifest", f"{INPUTS}/manifest_pa.yaml", *VALIDATE],
        "pressure_kpa",
    ),
    ("validate-models-unknown", ["validate", "--manifest", GOOD, "--models", "jelly"], "jelly"),
    ("shell-trial-without-pressure", ["shell", "--manifest", GOOD, "--group", ""], "pressure_kpa"),
    ("sensitivity-negative-duration", ["sensitivity", "--duration-s", "-1"], "duration"),
    (
        "validate-json-under-a-file",
        ["validate", "--manifest", GOOD, *VALIDATE, "--json", f"{INPUTS}/a_file.txt/v.json"],
        "--json",
    ),
    ("shell-out-is-a-folder", ["shell", "--manifest", GOOD, "--group", "", "--out", INPUTS], "--out"),
    ("events-log-missing", ["events", f"{INPUTS}/missing.csv"], "not found"),
]


# ---- outputs that cannot be written, every command that writes: (id, argv, field) --------------------
# Refused before anything runs (the demo before its training, validate before its fits), with the
# option named, never a traceback after the work was done.
OUTPUTS = [
    (
        "train-tensorboard_log",
        ["train", *TINY, "--params", *TINY_PPO_PARAMS, "-tb", f"{UNWRITABLE}/tb", "--run-dir", f"{OUT}/run"],
        "tensorboard_log",
    ),
    ("train-log_folder", ["train", *TINY, "--params", *TINY_PPO_PARAMS, "-f", f"{UNWRITABLE}/runs"], "log_folder"),
    ("train-run_dir", ["train", *TINY, "--params", *TINY_PPO_PARAMS, "--run-dir", f"{UNWRITABLE}/run"], "run_dir"),
    (
        "train-sweep-run_dir",
        ["train", *TINY, "--params", *TINY_PPO_PARAMS, "--seeds", "0", "1", "--run-dir", f"{UNWRITABLE}/sweep"],
        "run_dir",
    ),
    ("evaluate-out", ["evaluate", *GRID, "--controller", "zero", "--out", f"{UNWRITABLE}/eval"], "out"),
    (
        "evaluate-video",
        ["evaluate", *GRID, "--controller", "zero", "--out", f"{OUT}/eval", "--video", f"{UNWRITABLE}/video"],
        "video",
    ),
    (
        "validate-json",
        ["calibrate", "validate", "--manifest", GOOD, *VALIDATE, "--json", f"{UNWRITABLE}/v.json"],
        "--json",
    ),
    (
        "validate-plot",
        ["calibrate", "validate", "--manifest", GOOD, *VALIDATE, "--plot", f"{UNWRITABLE}/v.png"],
        "--plot",
    ),
    ("shell-out", ["calibrate", "shell", "--manifest", GOOD, "--group", "", "--out", f"{UNWRITABLE}/c.yaml"], "--out"),
    ("demo-out", ["demo", "--out", f"{UNWRITABLE}/demo"], "out"),
    ("demo-run_dir", ["demo", "--out", f"{OUT}/demo", "--run-dir", f"{UNWRITABLE}/run"], "run_dir"),
    ("export-out", ["export", RUN, "--out", f"{UNWRITABLE}/export"], "out"),
]


def _log_text(rows: int = 60, t_step: float = 2e7, unit_scale: float = 1.0, rate_scale: float = 1.0) -> str:
    """A RoboBall-format steer swing (ns timestamps) with θ and θ̇ scaled by the given factors."""
    t = np.arange(rows) * 0.02
    th = 0.3 * np.exp(-0.4 * t) * np.cos(3.0 * t)
    thd = np.gradient(th, t)
    lines = ["timestamp,roll_joint.position,roll_joint.velocity,ball_roll.position"]
    lines += [f"{i * t_step:.10g},{th[i] * unit_scale:.6g},{thd[i] * rate_scale:.6g},{-th[i]:.6g}" for i in range(rows)]
    return "\n".join(lines) + "\n"


# ---- robot logs through `sphere-env calibrate validate`: (id, log text, field) ----------------------------
DEG = 180 / np.pi
LOGS = [
    ("last-timestamp-inf", _log_text().rstrip("\n").rsplit("\n", 1)[0] + "\ninf,0,0,0\n", "not finite"),
    ("timestamp-inf-mid-log", _log_text().replace("\n400000000,", "\ninf,", 1), "timestamp"),
    ("theta-in-degrees", _log_text(unit_scale=DEG, rate_scale=DEG), "theta"),
    ("theta_dot-in-deg-per-s", _log_text(rate_scale=DEG), "theta_dot"),
    ("us-timestamps-read-as-ns", _log_text(t_step=2e4), "sample period"),
    ("s-timestamps-read-as-ns", _log_text(t_step=0.02), "sample period"),
    ("empty-file", "", "empty"),
    ("header-only", "timestamp,roll_joint.position\n", "empty"),
    ("not-a-number", "timestamp,roll_joint.position\n0,0.1\n20000000,abc\n40000000,0.1\n", "not a number"),
    ("duplicate-time", "timestamp,roll_joint.position\n0,0.1\n0,0.1\n20000000,0.1\n", "duplicate"),
    ("time-goes-back", "timestamp,roll_joint.position\n0,0.1\n40000000,0.1\n20000000,0.1\n", "increase"),
    (
        "long-NaN-run",
        "timestamp,roll_joint.position\n"
        + "".join(f"{i * 20000000},{'nan' if 3 <= i < 9 else 0.1}\n" for i in range(12)),
        "NaN",
    ),
    ("angle-1e308", "timestamp,roll_joint.position\n0,1e308\n20000000,0\n40000000,0\n", "theta"),
    ("binary-garbage", "\x00\x01\x02garbage\xff\n", "log"),
]


# ---- calibration files, loaded by ShellCalibration: (id, changes to the default file, field) -----------
# Changes map "a__b" (nested keys joined by "__") to a value (DELETE removes the key); a function of
# the default file gives them; a string is the file's whole text.
DELETE = object()


def _omega_n_in_hz(base: dict) -> dict:
    """The natural frequency entered in Hz instead of rad/s."""
    return {"omega_n__intercept_rad_s": float(base["omega_n"]["intercept_rad_s"] / (2 * np.pi))}


CALIBRATION_FILES = [
    ("omega_n-in-Hz", _omega_n_in_hz, "omega_n"),
    (
        "contact-volume-nan",
        {"contact_volume": {"model": "table", "pressure_kpa": [3.0, 14.0], "volume_m3": [float("nan"), 0.001]}},
        "volume_m3",
    ),
    (
        "pressure-range-in-Pa",
        {"pressure_range_kpa": [3000.0, 14000.0], "nominal_pressure_kpa": 4310.0},
        "pressure_range_kpa",
    ),
    (
        "pressure-range-in-MPa",
        {"pressure_range_kpa": [0.003, 0.014], "nominal_pressure_kpa": 0.00431},
        "pressure_range_kpa",
    ),
    ("pressure-range-bool", {"pressure_range_kpa": [True, 14.0]}, "pressure_range_kpa"),
    ("fitted_time_step_s-negative", {"hydroelastic__fitted_time_step_s": -0.005}, "fitted_time_step_s"),
    ("resolution_hint_m-1e6", {"hydroelastic__resolution_hint_m": 1e6}, "resolution_hint_m"),
    ("typo-key", {"nominal_pressure_kpaa": 6.0}, "nominal_pressure_kpaa"),
    ("zeta-negative", {"zeta__scale": -0.1}, "zeta"),
    ("not-a-mapping", "- 1\n- 2\n", "calibration"),
    ("malformed-yaml", "omega_n: {model: linear,\n", "calibration"),
    ("omega_n-missing", {"omega_n": DELETE}, "omega_n"),
]


def _calibration_text(changes) -> str:
    if isinstance(changes, str):
        return changes
    base = yaml.safe_load(asset_path("calibration", "default.yaml").read_text())
    base.pop("provenance", None)
    if callable(changes):
        changes = changes(base)
    for dotted, value in changes.items():
        *path, key = dotted.split("__")
        node = base
        for k in path:
            node = node[k]
        if value is DELETE:
            node.pop(key, None)
        else:
            node[key] = value
    return yaml.safe_dump(base)


# ---- fixtures ---------------------------------------------------------------------------------------
def _write(path, text: str):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def _manifest(path, log, **extra):
    entry = {"name": path.stem, "file": str(log), "fixture": "steer_plane", **extra}
    return _write(path, yaml.safe_dump({"data_root": ".", "trials": [entry]}))


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """The input files the cases point at (never an output folder)."""
    d = tmp_path_factory.mktemp("hostile_inputs")
    _write(d / "broken_config_run" / "config.yaml", "env_id: sphere_env/RampDescent-v0\nalgo: ppo\n")
    _write(d / "bad_yaml_run" / "config.yaml", "a: [1\n")
    _write(d / "a_file.txt", "not a folder\n")
    _write(d / "one_row_pme.csv", "t_s,omega_d\n0,1\n")
    good_log = _write(d / "logs" / "good.csv", _log_text())
    _manifest(d / "manifest_good.yaml", good_log)
    _manifest(d / "manifest_pa.yaml", good_log, pressure_kpa=8000)
    return d


@pytest.fixture(scope="module")
def runs(tmp_path_factory, tiny_ppo_run):
    """A copy of the shared tiny PPO run (``tests/conftest.py``), and a copy whose model.zip is cut
    to a third; the cases read them, the shared run stays untouched."""
    d = tmp_path_factory.mktemp("hostile_runs")
    for name in ("run", "truncated_run"):
        shutil.copytree(tiny_ppo_run, d / name)
    model = d / "truncated_run" / "model.zip"
    data = model.read_bytes()
    model.write_bytes(data[: len(data) // 3])
    return d


@pytest.fixture
def out(tmp_path):
    """The case's output folder: empty, and must stay so."""
    d = tmp_path / "out"
    d.mkdir()
    return d


def _resolve(argv, inputs, runs=None, **places) -> list[str]:
    subs = {INPUTS: str(inputs), **{"{" + k + "}": str(v) for k, v in places.items()}}
    if runs is not None:
        subs |= {RUN: str(runs / "run"), TRUNCATED_RUN: str(runs / "truncated_run")}
    resolved = []
    for a in argv:
        for key, value in subs.items():
            a = a.replace(key, value)
        resolved.append(a)
    return resolved


def _refused(argv, field, capsys, out):
    """Run `sphere-env ARGV`; assert exit code 2, one error line naming ``field``, no traceback, and
    nothing written to ``out``."""
    capsys.readouterr()
    try:
        code = sphere_env_cli(argv)
    except SystemExit as exc:
        code = exc.code
    err = capsys.readouterr().err
    errors = [line for line in err.splitlines() if "error:" in line]
    assert code == 2, err
    assert "Traceback" not in err, err
    assert len(errors) == 1, err
    assert field.lower() in errors[0].lower(), err
    assert not list(out.rglob("*")), "left in the output folder after the refusal"


def test_the_refusal_check_tells_a_wrong_refusal_apart(out, capsys):
    """The check can fail: an error naming another field, or a file left in the output folder."""
    argv = ["calibrate", "sensitivity", "--duration-s", "-1"]
    with pytest.raises(AssertionError):
        _refused(argv, "no_such_field", capsys, out)
    (out / "left.txt").write_text("x")
    with pytest.raises(AssertionError, match="left in the output folder"):
        _refused(argv, "duration", capsys, out)


# ---- the cases ----------------------------------------------------------------------------------------
def _ids(cases):
    return [pytest.param(*c[1:], id=c[0]) for c in cases]


@pytest.mark.parametrize("argv, field", _ids(TRAIN))
def test_train_refuses(argv, field, inputs, out, capsys):
    algo = argv[argv.index("--algo") + 1] if "--algo" in argv else "ppo"
    own, extra = (
        (argv[: argv.index("--params")], argv[argv.index("--params") + 1 :]) if "--params" in argv else (argv, [])
    )
    params = [*(TINY_PPO_PARAMS if algo == "ppo" else []), *extra]
    # the tiny env kwargs first: a case's own --env-kwargs are merged over them
    full = [*TINY, *own, *(["--params", *params] if params else []), "--run-dir", str(out / "run")]
    _refused(["train", *_resolve(full, inputs)], field, capsys, out)


def test_train_resume_refuses_a_bad_step_count(inputs, out, capsys):
    # a resume takes no other flag than -n, so the tiny run's flags of test_train_refuses are left out
    argv = ["train", "--resume", f"{INPUTS}/broken_config_run", "--n-timesteps", "nan", "--no-progress"]
    _refused(_resolve(argv, inputs), "n_timesteps", capsys, out)


@pytest.mark.parametrize("folder, field", _ids(TRAIN_RESUME))
def test_train_resume_refuses(folder, field, inputs, out, capsys):
    _refused(["train", "--resume", *_resolve([folder], inputs), "--no-progress"], field, capsys, out)


@pytest.mark.parametrize("argv, field", _ids(EVALUATE))
def test_evaluate_refuses(argv, field, inputs, out, capsys, request):
    runs = request.getfixturevalue("runs") if RUN in argv or TRUNCATED_RUN in argv else None
    full = [*GRID, *argv, *([] if "--out" in argv else ["--out", str(out / "out")])]
    _refused(["evaluate", *_resolve(full, inputs, runs)], field, capsys, out)


@pytest.mark.parametrize("argv, field", _ids(CALIBRATE))
def test_calibrate_refuses(argv, field, inputs, out, capsys):
    if argv[0] == "validate" and "--json" not in argv:
        argv = [*argv, "--json", str(out / "v.json"), "--plot", str(out / "v.png")]
    _refused(["calibrate", *_resolve(argv, inputs)], field, capsys, out)


@pytest.fixture(params=["proc", "read-only-folder"])
def unwritable(request, tmp_path):
    """A place no output can be written to: under ``/proc`` (refuses every new entry, even root's), or
    a folder without write permission (root ignores it, so that case runs for other users only)."""
    if request.param == "proc":
        if not sys.platform.startswith("linux"):
            pytest.skip("/proc is Linux's")
        yield "/proc/sphere_env_nope"
        return
    if os.geteuid() == 0:
        pytest.skip("root writes into a folder without write permission")
    ro = tmp_path / "read_only"
    ro.mkdir()
    ro.chmod(0o555)
    yield str(ro)
    ro.chmod(0o755)


@pytest.mark.parametrize("argv, field", _ids(OUTPUTS))
def test_an_output_that_cannot_be_written_is_refused_before_anything_runs(
    argv, field, inputs, out, unwritable, capsys, request
):
    runs = request.getfixturevalue("runs") if RUN in argv else None
    _refused(_resolve(argv, inputs, runs, unwritable=unwritable, out=out), field, capsys, out)


@pytest.mark.parametrize("text, field", _ids(LOGS))
def test_calibrate_validate_refuses_a_bad_log(text, field, tmp_path, out, capsys):
    log = _write(tmp_path / "logs" / "log.csv", text)
    manifest = _manifest(tmp_path / "manifest.yaml", log)
    _refused(
        [
            "calibrate",
            "validate",
            "--manifest",
            str(manifest),
            *VALIDATE,
            "--json",
            str(out / "v.json"),
            "--plot",
            str(out / "v.png"),
        ],
        field,
        capsys,
        out,
    )


@pytest.mark.parametrize("changes, field", _ids(CALIBRATION_FILES))
def test_shell_calibration_refuses_a_bad_file(changes, field, tmp_path):
    path = _write(tmp_path / "calibration.yaml", _calibration_text(changes))
    with pytest.raises(ValueError) as err:
        ShellCalibration.load(path)
    assert field.lower() in str(err.value).lower()


def test_make_refuses_a_calibration_that_is_not_a_path():
    with pytest.raises(ValueError, match="calibration"):
        gym.make("sphere_env/RampDescent-v0", shell_model="point", calibration=123)
