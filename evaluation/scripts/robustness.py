"""Robustness of the Gymnasium environments: action fuzzing and a memory soak.

* **Fuzz**: every env id × shell model, actions drawn from a mixture — uniform in [-1, 1], ±1e6,
  1e6-scale Gaussian, and vectors containing NaN or ±inf. NaN/inf must raise ``ValueError``
  (documented); everything else must step. No other exception may escape, observations must
  stay finite, and episodes end only by termination, time limit or a reported physics failure.
* **Interfaces** (:func:`fuzz_interfaces`): hostile train / evaluate / calibrate command lines,
  calibration files and robot logs; each must be refused with an error naming the field and leave
  nothing in its output folder.
* **Soak**: one process, one env (RampDescent-v0, injected shell, ``randomization="full"``: every
  reset resamples pressure, friction, ground μ, payload, incline, leak), random actions;
  resident memory (RSS) is sampled along the way.

Writes ``evaluation/results/robustness.md`` and ``.json``.

    python -m evaluation.scripts.robustness [--fuzz-steps 100000] [--soak-steps 200000]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from collections import Counter
from datetime import datetime, timezone

import gymnasium as gym
import numpy as np

import sphere_env  # noqa: F401
from sphere_env.models.shell import SHELL_MODELS

ENV_IDS = ("sphere_env/RampDescent-v0", "sphere_env/Roll-v0")
SOAK_LIMIT_MB = 50.0


def rss_mb() -> float:
    """Resident set size of this process [MB] (Linux /proc)."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6


def fuzz_action(rng: np.random.Generator) -> tuple[np.ndarray, str]:
    k = rng.random()
    if k < 0.4:
        return rng.uniform(-1, 1, 2).astype(np.float32), "uniform"
    if k < 0.6:
        return rng.choice([-1e6, 1e6], 2), "pm1e6"
    if k < 0.75:
        return rng.normal(0, 1e6, 2), "gauss1e6"
    a = rng.uniform(-1, 1, 2)
    if k < 0.875:
        a[rng.integers(2)] = np.nan
        return a, "nan"
    a[rng.integers(2)] = rng.choice([np.inf, -np.inf])
    return a, "inf"


def fuzz(env_id: str, shell_model: str, steps: int, seed: int = 0) -> dict:
    env = gym.make(env_id, shell_model=shell_model, randomization="full")
    rng = np.random.default_rng(seed)
    counts, ends = Counter(), Counter()
    bad_obs = 0
    unexpected: list[str] = []
    env.reset(seed=seed)
    t0 = time.perf_counter()
    for _ in range(steps):
        a, kind = fuzz_action(rng)
        counts[kind] += 1
        try:
            obs, r, term, trunc, info = env.step(a)
        except ValueError as err:
            if kind in ("nan", "inf") and "action" in str(err):
                counts["raised_as_documented"] += 1
                continue
            unexpected.append(f"{kind}: {type(err).__name__}: {err}")
            env.reset()
            continue
        except Exception as err:  # anything else is a bug
            unexpected.append(f"{kind}: {type(err).__name__}: {err}")
            env.reset()
            continue
        if kind in ("nan", "inf"):
            unexpected.append(f"{kind}: stepped without raising")
        if not (np.all(np.isfinite(obs)) and np.isfinite(r)):
            bad_obs += 1
        if term or trunc:
            reason = info.get("truncation_reason")
            ends["physics_failure" if reason else ("success" if info.get("is_success") else
                 ("terminated" if term else "time_limit"))] += 1
            env.reset()
    wall = time.perf_counter() - t0
    env.close()
    return dict(env=env_id.split("/")[1], shell_model=shell_model, steps=steps,
                advanced=steps - counts["raised_as_documented"], wall_s=wall,
                nan_inf_raised=counts["raised_as_documented"], nan_inf_sent=counts["nan"] + counts["inf"],
                huge_sent=counts["pm1e6"] + counts["gauss1e6"], episodes=sum(ends.values()),
                physics_failures=ends["physics_failure"], success=ends["success"],
                non_finite_outputs=bad_obs, unexpected=len(unexpected), unexpected_examples=unexpected[:5])


def soak(steps: int, seed: int = 0, sample_every: int = 10_000) -> dict:
    rss0 = rss_mb()
    env = gym.make("sphere_env/RampDescent-v0", shell_model="injected", randomization="full")
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)
    rss_built = rss_mb()
    samples = []
    episodes = failures = 0
    t0 = time.perf_counter()
    for i in range(1, steps + 1):
        obs, r, term, trunc, info = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
        if term or trunc:
            episodes += 1
            failures += "truncation_reason" in info
            env.reset()
        if i % sample_every == 0:
            samples.append((i, rss_mb()))
    wall = time.perf_counter() - t0
    twins = env.unwrapped.cached_twin_count
    env.close()
    warm = samples[0][1]
    return dict(steps=steps, wall_s=wall, episodes=episodes, physics_failures=failures,
                twins_cached=twins,
                rss_start_mb=rss0, rss_after_build_mb=rss_built, rss_first_sample_mb=warm,
                rss_end_mb=samples[-1][1], growth_from_build_mb=samples[-1][1] - rss_built,
                growth_after_first_sample_mb=samples[-1][1] - warm, samples=samples,
                ok=samples[-1][1] - rss_built <= SOAK_LIMIT_MB)


# ---- interfaces: CLI arguments, calibration files, log files ------------------------------------------
# Hostile inputs through the public entry points (train / evaluate / calibrate CLIs, calibration
# files, robot logs). Each case runs in-process with its outputs pointed into a fresh empty folder
# and is classified as: a clear error (refused with a message naming ``expect``), another exception
# (a traceback, or a refusal that does not name the field), or silent acceptance (exit 0); and,
# independently, half-written output (anything left in the case's folder after a refusal).

def _bad_shape_controller(obs, info=None):
    """A user controller returning three numbers instead of two."""
    return np.zeros(3)


def _write(path, text: str):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def _log_text(rows: int = 60, t_step: float = 2e7, unit_scale: float = 1.0, rate_scale: float = 1.0) -> str:
    """A RoboBall-format steer swing (ns timestamps) with θ and θ̇ scaled by the given factors."""
    t = np.arange(rows) * 0.02
    th = 0.3 * np.exp(-0.4 * t) * np.cos(3.0 * t)
    thd = np.gradient(th, t)
    lines = ["timestamp,roll_joint.position,roll_joint.velocity,ball_roll.position"]
    lines += [f"{i * t_step:.10g},{th[i] * unit_scale:.6g},{thd[i] * rate_scale:.6g},{-th[i]:.6g}" for i in range(rows)]
    return "\n".join(lines) + "\n"


def _calibration_cases(work) -> list[tuple[str, str, str]]:
    """(name, YAML text of a calibration file, field the refusal must name)."""
    import yaml

    from sphere_env.resources import asset_path

    base = yaml.safe_load(asset_path("calibration", "default.yaml").read_text())
    base.pop("provenance", None)

    def variant(**changes):
        d = yaml.safe_load(yaml.safe_dump(base))
        for dotted, v in changes.items():
            keys = dotted.split("__")
            node = d
            for k in keys[:-1]:
                node = node[k]
            if v is _DELETE:
                node.pop(keys[-1], None)
            else:
                node[keys[-1]] = v
        return yaml.safe_dump(d)

    hz = base["omega_n"]["intercept_rad_s"] / (2 * np.pi)
    return [
        ("omega_n in Hz (K_inject < 0)", variant(omega_n__intercept_rad_s=float(hz)), "omega_n"),
        ("NaN contact volume", variant(contact_volume={"model": "table", "pressure_kpa": [3.0, 14.0],
                                                       "volume_m3": [float("nan"), 0.001]}), "volume_m3"),
        ("pressure range in Pa", variant(pressure_range_kpa=[3000.0, 14000.0], nominal_pressure_kpa=4310.0),
         "pressure_range_kpa"),
        ("pressure range in MPa", variant(pressure_range_kpa=[0.003, 0.014], nominal_pressure_kpa=0.00431),
         "pressure_range_kpa"),
        ("bool in pressure range", variant(pressure_range_kpa=[True, 14.0]), "pressure_range_kpa"),
        ("negative fitted_time_step_s", variant(hydroelastic__fitted_time_step_s=-0.005), "fitted_time_step_s"),
        ("resolution_hint_m 1e6", variant(hydroelastic__resolution_hint_m=1e6), "resolution_hint_m"),
        ("typo key nominal_pressure_kpaa", variant(nominal_pressure_kpaa=6.0), "nominal_pressure_kpaa"),
        ("zeta negative", variant(zeta__scale=-0.1), "zeta"),
        ("not a mapping", "- 1\n- 2\n", "calibration"),
        ("malformed YAML", "omega_n: {model: linear,\n", "calibration"),
        ("missing omega_n", variant(omega_n=_DELETE), "omega_n"),
    ]


_DELETE = object()


def _interface_cases(work) -> list[dict]:
    """Every hostile case: category, name, a callable running it in-process, the field the error
    must name and the folder that must stay empty."""
    from sphere_env.cli import main as sphere_env_cli

    def calibrate(argv):  # through the public `sphere-env calibrate` entry point
        return sphere_env_cli(["calibrate", *argv])

    from sphere_env.evaluation.evaluate import main as evaluate
    from sphere_env.training.train import main as train

    inputs = work / "inputs"
    inputs.mkdir(parents=True, exist_ok=True)
    cases: list[dict] = []

    def add(category, name, fn, expect):
        cases.append(dict(category=category, name=name, fn=fn, expect=expect))

    tiny = ["--n-timesteps", "10", "--no-progress", "--params", "n_envs:1", "n_steps:32", "batch_size:32",
            "n_epochs:1", "env_kwargs:{shell_model: point}"]
    train_bad = [
        (["--params", "ent_coef:abc"], "hyperparams.ent_coef"), (["--params", "n_epochs:0"], "hyperparams.n_epochs"),
        (["--params", "gamma:2.0"], "hyperparams.gamma"), (["--params", "gae_lambda:-0.5"], "hyperparams.gae_lambda"),
        (["--params", "learning_rate:0"], "hyperparams.learning_rate"),
        (["--params", "learning_rate:lin_x"], "hyperparams.learning_rate"),
        (["--params", "clip_range:-0.2"], "hyperparams.clip_range"),
        (["--params", "max_grad_norm:0"], "hyperparams.max_grad_norm"),
        (["--params", "batch_size:0"], "hyperparams.batch_size"), (["--params", "n_steps:1.5"], "hyperparams.n_steps"),
        (["--params", "vf_coef:.nan"], "hyperparams.vf_coef"), (["--params", "policy_kwargs:5"], "hyperparams.policy_kwargs"),
        (["--params", "learning_rat:1e-3"], "hyperparams.learning_rat"), (["--params", "n_envs:0"], "n_envs"),
        (["--params", "n_envs:abc"], "n_envs"), (["--params", "noequals"], "params"),
        (["--params", "randomization:{pressure_kpa: [14, 3]}"], "randomization.pressure_kpa"),
        (["--params", "randomization:{pressure_kpa: {distribution: uniform}, "
                      "pressure_schedule: {rate_kpa_per_s: [0.5, -0.5]}}"], "randomization"),
        (["--params", "env_kwargs:[1, 2]"], "env_kwargs"), (["--params", "env_kwargs:{shell_model: jelly}"], "shell_model"),
        (["--params", "normalize:{norm_ob: true}"], "normalize.norm_ob"), (["--algo", "dqn"], "algo"),
        (["--env", "sphere_env/Nope-v0"], "env"), (["--n-timesteps", "0"], "n_timesteps"),
        (["--n-timesteps", "nan"], "n_timesteps"), (["--eval-episodes", "0"], "eval_episodes"),
        (["--checkpoint-freq", "0"], "checkpoint_freq"), (["--torch-threads", "0"], "torch_threads"),
        (["--seed", "-1"], "seed"),
        (["--resume", str(inputs / "broken_config_run"), "--n-timesteps", "nan"], "n_timesteps"),
        (["--algo", "sac", "--params", "ent_coef:auto_-1"], "hyperparams.ent_coef"),
        (["--algo", "sac", "--params", "train_freq:[1, hour]"], "hyperparams.train_freq"),
        (["--algo", "sac", "--params", "tau:0"], "hyperparams.tau"),
    ]
    def train_argv(argv, d):
        algo = argv[argv.index("--algo") + 1] if "--algo" in argv else "ppo"
        params = (tiny[tiny.index("--params") + 1:] if algo == "ppo" else ["env_kwargs:{shell_model: point}"])
        extra = argv[argv.index("--params") + 1:] if "--params" in argv else []
        other = argv[:argv.index("--params")] if "--params" in argv else argv
        return ["--n-timesteps", "10", "--no-progress", *other, "--params", *params, *extra,
                "--run-dir", str(d / "run")]

    for argv, expect in train_bad:
        add("train CLI", " ".join(argv), lambda d, argv=argv: train(train_argv(argv, d)), expect)
    _write(inputs / "broken_config_run" / "config.yaml", "env_id: sphere_env/RampDescent-v0\nalgo: ppo\n")
    add("train CLI", "--resume with an unreadable config.yaml",
        lambda d: train(["--resume", str(_write(inputs / "bad_yaml_run" / "config.yaml", "a: [1\n").parent),
                         "--no-progress"]), "config.yaml")
    add("train CLI", "--resume of a folder without config.yaml",
        lambda d: train(["--resume", str(inputs / "not_a_run"), "--no-progress"]), "config.yaml")

    # A tiny trained run (valid), then a copy with a truncated model.
    run = work / "tiny_run"
    if not (run / "model.zip").exists():
        train([*tiny, "--run-dir", str(run)])
    import shutil

    broken = inputs / "truncated_run"
    if not broken.exists():
        shutil.copytree(run, broken)
        data = (broken / "model.zip").read_bytes()
        (broken / "model.zip").write_bytes(data[: len(data) // 3])
    grid = ["--replay", "--pressures", "8.5", "--shell-models", "point", "--seeds", "0", "--workers", "1"]
    a_file = _write(inputs / "a_file.txt", "not a folder\n")
    one_row = _write(inputs / "one_row_pme.csv", "t_s,omega_d\n0,1\n")
    eval_bad = [
        (["--controller", str(broken)], "model.zip"),
        (["--controller", "zero", "--env-kwargs", "{shell_model: point}"], "env_kwargs.shell_model"),
        (["--controller", "zero", "--env-kwargs", "{a: 1, a: 2}"], "env_kwargs"),
        (["--controller", "zero", "--env-kwargs", "{a: [1"], "env_kwargs"),
        (["--controller", "zero", "--env-kwargs", "[1, 2]"], "env_kwargs"),
        (["--controller", "zero", "--env-kwargs", "{no_such_kwarg: 1}"], "no_such_kwarg"),
        (["--controller", "sphere_env.evaluation.scripts.robustness:_bad_shape_controller"], "shape"),
        (["--controller", "no_such_module:f"], "controller"),
        (["--controller", str(run), "--env", "sphere_env/Roll-v0"], "--allow-env-mismatch"),
        (["--controller", "zero", "--pressures", "1000"], "pressures"),
        (["--controller", "zero", "--shell-models", "jelly"], "shell_models"),
        (["--controller", "zero", "--friction", "bogus"], "friction"),
        (["--controller", "zero", "--pme-log", str(inputs / "missing.csv")], "pme_log"),
        (["--controller", "zero", "--pme-log", str(one_row)], "pme_log"),
        (["--controller", "zero", "--seeds", "-1"], "seeds"),
        (["--controller", "zero", "--replay", "zero,point,99"], "replay"),
        (["--controller", "zero", "--pme-reference", "jelly"], "pme_reference"),
        (["--controller", "zero", "--workers", "0"], "workers"),
    ]
    for argv, expect in eval_bad:
        add("evaluate CLI", " ".join(argv).replace(str(work), "…"),
            lambda d, argv=argv: evaluate([*grid, *argv, "--out", str(d / "out")]), expect)
    add("evaluate CLI", "--out pointing at a file",
        lambda d: evaluate(["--controller", "zero", "--out", str(a_file), *grid]), "out")

    # Calibration CLI (manifests and logs written into inputs/).
    good_log = _write(inputs / "logs" / "good.csv", _log_text())

    def manifest(name, file, **extra):
        import yaml

        entry = {"name": name, "file": str(file), "fixture": "steer_plane", **extra}
        return _write(inputs / f"manifest_{name}.yaml", yaml.safe_dump({"data_root": ".", "trials": [entry]}))

    vbase = ["--models", "point", "--drive-friction", "none"]
    cal_bad = [
        (["validate", "--manifest", str(manifest("good", good_log)), *vbase, "--tol", "bogus=1"], "bogus"),
        (["validate", "--manifest", str(manifest("good", good_log)), *vbase, "--tol", "theta=abc"], "theta"),
        (["validate", "--manifest", str(manifest("good", good_log)), *vbase, "--workers", "0"], "workers"),
        (["validate", "--manifest", str(inputs / "missing.yaml"), *vbase], "manifest"),
        (["validate", "--manifest", str(manifest("pa", good_log, pressure_kpa=8000)), *vbase], "pressure_kpa"),
        (["validate", "--manifest", str(manifest("good", good_log)), "--models", "jelly"], "jelly"),
        (["shell", "--manifest", str(manifest("good", good_log)), "--group", ""], "pressure_kpa"),
        (["sensitivity", "--duration-s", "-1"], "duration"),
        (["validate", "--manifest", str(manifest("good", good_log)), *vbase, "--json",
          str(inputs / "a_file.txt" / "v.json")], "--json"),
        (["shell", "--manifest", str(manifest("good", good_log)), "--group", "", "--out", str(inputs)], "--out"),
        (["events", str(inputs / "missing.csv")], "not found"),
    ]
    for argv, expect in cal_bad:
        add("calibrate CLI", " ".join(argv).replace(str(work), "…"),
            lambda d, argv=argv: _calibrate_exit(calibrate, [*argv, *(["--json", str(d / "v.json"), "--plot",
                                                 str(d / "v.png")] if argv[0] == "validate" and "--json" not in argv
                                                 else [])]), expect)

    # Calibration files: loaded by ShellCalibration, by an env, and by `validate --calibration`.
    from sphere_env.models.shell import ShellCalibration

    for name, text, expect in _calibration_cases(work):
        path = _write(inputs / "calibrations" / f"{name.replace(' ', '_')}.yaml", text)
        add("calibration file", name, lambda d, path=path: ShellCalibration.load(path), expect)
    add("calibration file", "calibration=123 (not a path)",
        lambda d: gym.make("sphere_env/RampDescent-v0", shell_model="point", calibration=123), "calibration")

    # Log files, through `validate` (the path that hung on an infinite timestamp).
    logs = {
        "last timestamp inf": (_log_text().rstrip("\n").rsplit("\n", 1)[0] + "\ninf,0,0,0\n", "not finite"),
        "timestamp inf mid-log": (_log_text().replace("\n400000000,", "\ninf,", 1), "timestamp"),
        "theta in degrees": (_log_text(unit_scale=180 / np.pi, rate_scale=180 / np.pi), "theta"),
        "theta_dot in deg/s": (_log_text(rate_scale=180 / np.pi), "theta_dot"),
        "µs timestamps read as ns": (_log_text(t_step=2e4), "sample period"),
        "s timestamps read as ns": (_log_text(t_step=0.02), "sample period"),
        "empty file": ("", "empty"),
        "header only": ("timestamp,roll_joint.position\n", "empty"),
        "not a number": ("timestamp,roll_joint.position\n0,0.1\n20000000,abc\n40000000,0.1\n", "not a number"),
        "duplicate time": ("timestamp,roll_joint.position\n0,0.1\n0,0.1\n20000000,0.1\n", "duplicate"),
        "time goes back": ("timestamp,roll_joint.position\n0,0.1\n40000000,0.1\n20000000,0.1\n", "increase"),
        "long NaN run": ("timestamp,roll_joint.position\n" + "".join(
            f"{i * 20000000},{'nan' if 3 <= i < 9 else 0.1}\n" for i in range(12)), "NaN"),
        "1e308 angle": ("timestamp,roll_joint.position\n0,1e308\n20000000,0\n40000000,0\n", "theta"),
        "binary garbage": ("\x00\x01\x02garbage\xff\n", "log"),
    }
    for name, (text, expect) in logs.items():
        path = _write(inputs / "logs" / f"{abs(hash(name))}.csv", text)
        man = manifest(f"log{abs(hash(name))}", path)
        add("log file", name, lambda d, man=man: _calibrate_exit(
            calibrate, ["validate", "--manifest", str(man), *vbase, "--json", str(d / "v.json"),
                        "--plot", str(d / "v.png")]), expect)
    return cases


def _calibrate_exit(calibrate, argv):
    """The calibration CLI returns its exit code; turn a non-zero one into SystemExit as argparse does."""
    code = calibrate(argv)
    if code:
        raise SystemExit(code)
    return code


def fuzz_interfaces(work=None) -> dict:
    """Run every interface case; count tried / clear error / other exception / silent acceptance /
    half-written output. ``work`` holds inputs and one empty output folder per case."""
    import contextlib
    import io
    import shutil
    import tempfile
    from pathlib import Path

    own = work is None
    work = Path(tempfile.mkdtemp(prefix="sphere_env_interfaces_")) if own else Path(work)
    t0 = time.perf_counter()
    rows: list[dict] = []
    try:
        cases = _interface_cases(work)
        for i, case in enumerate(cases):
            d = work / "cases" / f"{i:03d}"
            d.mkdir(parents=True)
            err_buf, out_buf = io.StringIO(), io.StringIO()
            outcome, message = "", ""
            try:
                with contextlib.redirect_stderr(err_buf), contextlib.redirect_stdout(out_buf):
                    case["fn"](d)
                outcome = "silent acceptance"
            except SystemExit as exc:
                message = " ".join(err_buf.getvalue().split())
                outcome = "clear error" if exc.code not in (0, None) and case["expect"].lower() in message.lower() \
                    else ("silent acceptance" if exc.code in (0, None) else "other exception")
            except ValueError as exc:
                message = str(exc)
                outcome = "clear error" if case["expect"].lower() in message.lower() else "other exception"
            except Exception as exc:  # noqa: BLE001 - counted, that is the point
                message = f"{type(exc).__name__}: {exc}"
                outcome = "other exception"
            left = sorted(str(p.relative_to(d)) for p in d.rglob("*"))
            half = bool(left) and outcome != "silent acceptance"
            rows.append(dict(category=case["category"], case=case["name"], outcome=outcome,
                             half_written=half, left_behind=left[:5], message=message[-300:]))
    finally:
        if own:
            shutil.rmtree(work, ignore_errors=True)
    summary: dict = {"wall_s": time.perf_counter() - t0, "cases": rows, "by_category": {}}
    for cat in dict.fromkeys(r["category"] for r in rows):
        rs = [r for r in rows if r["category"] == cat]
        summary["by_category"][cat] = _interface_counts(rs)
    summary["total"] = _interface_counts(rows)
    return summary


def _interface_counts(rows: list[dict]) -> dict:
    c = Counter(r["outcome"] for r in rows)
    return {"tried": len(rows), "clear_error": c["clear error"], "other_exception": c["other exception"],
            "silent_acceptance": c["silent acceptance"], "half_written": sum(r["half_written"] for r in rows)}


def interfaces_markdown(res: dict) -> list[str]:
    """The report section of :func:`fuzz_interfaces`."""
    from sphere_env.evaluation._report import markdown_table

    t = res["total"]
    table = [{"category": k, **v} for k, v in res["by_category"].items()] + [{"category": "**all**", **t}]
    cols = [("category", "interface", ""), ("tried", "tried", "{}"), ("clear_error", "clear error", "{}"),
            ("other_exception", "other exception", "{}"), ("silent_acceptance", "silent acceptance", "{}"),
            ("half_written", "half-written output", "{}")]
    md = [f"## Interfaces: {t['tried']} hostile inputs, {t['clear_error']} refused with a named error",
          "",
          "Train / evaluate / calibrate command lines, calibration files and robot logs, run in-process with "
          "outputs pointed into a fresh empty folder per case. *Clear error*: refused with a message naming "
          "the field; *other exception*: a traceback or a message that does not name it; *silent acceptance*: "
          "exit 0; *half-written*: anything left in the case's folder after a refusal. "
          f"{res['wall_s']:.0f} s wall.",
          "",
          markdown_table(table, cols),
          ""]
    bad = [r for r in res["cases"] if r["outcome"] != "clear error" or r["half_written"]]
    if bad:
        md += ["Cases not refused cleanly:", ""]
        md += [f"- {r['category']}: `{r['case']}` → {r['outcome']}"
               f"{' (left ' + ', '.join(r['left_behind']) + ')' if r['half_written'] else ''}: {r['message'][:160]}"
               for r in bad]
        md.append("")
    return md


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--fuzz-steps", type=int, default=135_000,
                        help="total step() calls over all cases (~25%% are NaN/inf and raise; ~1e5 simulated)")
    parser.add_argument("--soak-steps", type=int, default=200_000)
    args = parser.parse_args(argv)
    from sphere_env.evaluation._report import RESULTS, machine_info, markdown_table

    info = machine_info()  # at the start: the commit that is actually run
    s = soak(args.soak_steps)  # first, in a fresh process heap
    print({k: v for k, v in s.items() if k != "samples"}, flush=True)
    # Hydroelastic is ~5x slower per step: give it a third of the point/injected share.
    weights = {"point": 3, "injected": 3, "hydroelastic": 1}
    total_w = sum(weights.values()) * len(ENV_IDS)
    rows = []
    for env_id in ENV_IDS:
        for sm in SHELL_MODELS:
            n = int(np.ceil(args.fuzz_steps * weights[sm] / total_w))
            rows.append(fuzz(env_id, sm, n))
            print(rows[-1], flush=True)
    fuzz_total = sum(r["steps"] for r in rows)
    fuzz_advanced = sum(r["advanced"] for r in rows)
    unexpected = sum(r["unexpected"] for r in rows)
    cols = [("env", "env", ""), ("shell_model", "shell", ""), ("steps", "step() calls", "{}"),
            ("advanced", "steps simulated", "{}"), ("wall_s", "wall s", "{:.0f}"),
            ("huge_sent", "±1e6 / 1e6σ actions", "{}"), ("nan_inf_sent", "NaN/inf actions", "{}"),
            ("nan_inf_raised", "…raised ValueError", "{}"), ("episodes", "episodes", "{}"),
            ("physics_failures", "physics-failure truncations", "{}"), ("non_finite_outputs", "non-finite obs/reward", "{}"),
            ("unexpected", "unexpected exceptions", "{}")]
    md = [
        "# sphere_env robustness",
        "",
        f"Generated {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC "
        f"by `python -m evaluation.scripts.robustness` "
        f"(commit {info['commit']}); {info['cpu']}, {info['cores']} cores, shared with other jobs.",
        "",
        f"## Fuzzed actions: {fuzz_total} step() calls ({fuzz_advanced} simulated), {unexpected} unexpected exceptions",
        "",
        "Actions: 40% uniform [-1, 1], 20% ±1e6, 15% N(0, 1e6²), 12.5% with a NaN, 12.5% with ±inf; "
        "`randomization=\"full\"`. NaN/inf must raise `ValueError` naming the action (and the env stays usable); "
        "everything else is clipped and stepped.",
        "",
        markdown_table(rows, cols),
        "",
        f"## Soak: {s['steps']} steps in one process",
        "",
        f"RampDescent-v0, injected shell, `randomization=\"full\"`, random actions: {s['episodes']} episodes, "
        f"{s['physics_failures']} physics-failure truncations, {s['twins_cached']} twins cached (one per "
        f"1° incline), {s['wall_s']:.0f} s wall.",
        "",
        f"- RSS after building the env: {s['rss_after_build_mb']:.1f} MB; after {s['samples'][0][0]} steps: "
        f"{s['rss_first_sample_mb']:.1f} MB; at the end: {s['rss_end_mb']:.1f} MB.",
        f"- **Growth over the soak: {s['growth_from_build_mb']:+.1f} MB** (limit {SOAK_LIMIT_MB:.0f} MB: "
        f"{'met' if s['ok'] else 'NOT met'}); after the first {s['samples'][0][0]} steps (twin cache for the "
        f"sampled inclines warm): {s['growth_after_first_sample_mb']:+.1f} MB.",
        f"- RSS samples (step, MB): {', '.join(f'({i}, {m:.1f})' for i, m in s['samples'])}",
    ]
    interfaces = fuzz_interfaces()
    md += [""] + interfaces_markdown(interfaces)
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "robustness.md").write_text("\n".join(md) + "\n")
    (RESULTS / "robustness.json").write_text(json.dumps({"machine": info, "fuzz": rows, "soak": s,
                                                         "interfaces": interfaces}, indent=2))
    print("\n".join(md))


if __name__ == "__main__":
    main()
