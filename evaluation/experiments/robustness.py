"""Robustness of the Gymnasium environments: hostile inputs, action fuzzing and memory soaks.

* **Hostile inputs** (:func:`hostile_inputs`): every env id × shell model gets hostile ``gym.make``
  kwargs, randomization specs, ``reset`` options and seeds on a running episode, and actions of
  the wrong shape or type; step() after an episode ended and on a mid-episode copy; configurations
  whose explicit torques diverge at the plant step. Real physics failures (launched states) are
  driven through the truncation path. Each input is counted as a clear error, another exception, a
  silent acceptance or a half-written env (the error came, but the env changed).
* **Interfaces** (:func:`fuzz_interfaces`): hostile train / evaluate / calibrate command lines,
  calibration files and robot logs; each must be refused with an error naming the field and leave
  nothing in its output folder.
* **Action fuzz** (:func:`fuzz`): actions from a mixture — uniform in [-1, 1], ±1e6, 1e6-scale
  Gaussian, vectors containing NaN or ±inf. NaN/inf must raise ``ValueError`` (documented);
  everything else is clipped and stepped; observations must stay finite.
* **Soak** (:func:`soak`): one env per shell model (RampDescent-v0, ``randomization="full"``),
  random actions; resident memory (RSS) sampled along the way, resets timed.

Writes ``evaluation/results/robustness.md`` and ``.json`` (temp name, then renamed).

    python -m evaluation.experiments.robustness [--fuzz-steps 60000] [--soak-steps 40000] [--hydroelastic-soak-steps N]
    python -m evaluation.experiments.robustness --soak-only ...   # replace only the soak results
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import pickle
import time
from collections import Counter
from datetime import datetime, timezone
from typing import Any

import gymnasium as gym
import numpy as np

import sphere_env  # noqa: F401
from sphere_env.files import write_text_atomic
from sphere_env.models.shell import SHELL_MODELS
from sphere_env.physics import Twin

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


def soak(steps: int, seed: int = 0, sample_every: int = 10_000, shell_model: str = "injected",
         env_id: str = "sphere_env/RampDescent-v0") -> dict:
    """Run one env for ``steps`` random-action steps under ``randomization="full"``; sample RSS
    every ``sample_every`` steps and time every reset. Median and p95 reset are over the second
    half of the resets (caches warm)."""
    rss0 = rss_mb()
    env = gym.make(env_id, shell_model=shell_model, randomization="full")
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)
    rss_built = rss_mb()
    samples = []
    reset_s: list[float] = []
    reset_cpu_s: list[float] = []  # CPU time of this process: what the reset costs without waiting for a core
    episodes = failures = 0
    t0 = time.perf_counter()
    for i in range(1, steps + 1):
        obs, r, term, trunc, info = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
        if term or trunc:
            episodes += 1
            failures += "truncation_reason" in info
            t_r, c_r = time.perf_counter(), time.process_time()
            env.reset()
            reset_s.append(time.perf_counter() - t_r)
            reset_cpu_s.append(time.process_time() - c_r)
        if i % sample_every == 0:
            samples.append((i, rss_mb()))
    wall = time.perf_counter() - t0
    twins = env.unwrapped.cached_twin_count
    shells = env.unwrapped.cached_shell_count
    env.close()
    warm = samples[0][1]
    late = sorted(reset_s[len(reset_s) // 2:]) or [float("nan")]
    late_cpu = reset_cpu_s[len(reset_cpu_s) // 2:] or [float("nan")]
    return dict(env=env_id.split("/")[1], shell_model=shell_model, steps=steps, wall_s=wall,
                steps_per_s=steps / wall, episodes=episodes, physics_failures=failures,
                twins_cached=twins, shells_cached=shells,
                rss_start_mb=rss0, rss_after_build_mb=rss_built, rss_first_sample_mb=warm,
                rss_end_mb=samples[-1][1], growth_from_build_mb=samples[-1][1] - rss_built,
                growth_after_first_sample_mb=samples[-1][1] - warm, samples=samples,
                median_reset_ms=1e3 * float(np.median(late)), p95_reset_ms=1e3 * float(np.percentile(late, 95)),
                median_reset_cpu_ms=1e3 * float(np.median(late_cpu)),
                max_reset_ms=1e3 * max(reset_s, default=float("nan")),
                ok=samples[-1][1] - rss_built <= SOAK_LIMIT_MB)


# ---- hostile inputs at the environment boundary --------------------------------------------------
# Each case is an input the environment must refuse. Outcomes: ``clear_error`` (the documented
# exception type, its message naming the field), ``other_exception`` (another type, or a message
# that names nothing), ``silent_acceptance`` (no error), ``half_written`` (the error came, but the
# environment changed: its next steps differ from an identical twin environment's that never saw
# the input). Everything but ``clear_error`` is a bug.
OUTCOMES = ("clear_error", "other_exception", "silent_acceptance", "half_written")
NAN = float("nan")


class Tally:
    """Counts of outcomes per group of cases, with a few examples of each failure."""

    def __init__(self):
        self.counts: dict[str, Counter] = {}
        self.examples: list[str] = []

    def add(self, group: str, case: str, outcome: str, detail: str = "") -> None:
        self.counts.setdefault(group, Counter())[outcome] += 1
        if outcome != "clear_error" and len(self.examples) < 40:
            self.examples.append(f"{group}: {case}: {outcome} {detail}"[:300])

    def expect(self, group: str, case: str, fn, field: str, exc=(ValueError,)) -> bool:
        """Run ``fn``; True if it raised ``exc`` naming ``field``."""
        try:
            out = fn()
        except exc as err:
            if field in str(err):
                self.add(group, case, "clear_error")
                return True
            self.add(group, case, "other_exception", f"{type(err).__name__}: {err}")
            return False
        except Exception as err:  # noqa: BLE001 - classifying is the point
            self.add(group, case, "other_exception", f"{type(err).__name__}: {err}")
            return False
        if hasattr(out, "close"):
            out.close()
        self.add(group, case, "silent_acceptance")
        return False

    def rows(self) -> list[dict]:
        rows = [dict(group=g, tried=sum(c.values()), **{o: c[o] for o in OUTCOMES}) for g, c in self.counts.items()]
        rows.append(dict(group="total", tried=sum(r["tried"] for r in rows),
                         **{o: sum(r[o] for r in rows) for o in OUTCOMES}))
        return rows


def kwarg_cases(env_id: str) -> list[tuple[dict, str]]:
    """(kwargs, field the error must name) for gym.make."""
    cases = [
        (dict(shell_model="rubber"), "shell_model"), (dict(shell_model=None), "shell_model"),
        (dict(friction_model="sticky"), "friction_model"), (dict(friction_model=3), "friction_model"),
        (dict(friction_model={"law": "viscous", "params": {"c": -1.0}}), "friction_model"),
        (dict(friction_model={"law": "viscous", "params": {"c": 300.0}}), "friction_model"),
        (dict(friction_model={"drive": {"law": "viscous", "params": {"c": 1e4}}}), "friction_model"),
        (dict(calibration="/nonexistent/cal.yaml"), "calibration"), (dict(calibration=123), "calibration"),
        (dict(control_frequency_hz=0), "control_frequency_hz"), (dict(control_frequency_hz=NAN), "control_frequency_hz"),
        (dict(control_frequency_hz="fast"), "control_frequency_hz"), (dict(control_frequency_hz=33.0), "control_frequency_hz"),
        (dict(control_frequency_hz=1e9), "control_frequency_hz"),
        (dict(time_step_s=0.0), "time_step_s"), (dict(time_step_s=1.0), "time_step_s"), (dict(time_step_s="x"), "time_step_s"),
        (dict(steer_torque_limit_nm=0.0), "steer_torque_limit_nm"), (dict(steer_torque_limit_nm=1e9), "steer_torque_limit_nm"),
        (dict(drive_torque_limit_nm=-1.0), "drive_torque_limit_nm"), (dict(drive_torque_limit_nm=NAN), "drive_torque_limit_nm"),
        (dict(observe_pressure="yes"), "observe_pressure"), (dict(observe_pressure=1), "observe_pressure"),
        (dict(observation_noise_scale=-1.0), "observation_noise_scale"),
        (dict(observation_noise_scale=1e40), "observation_noise_scale"),
        (dict(observation_noise_scale=NAN), "observation_noise_scale"),
        (dict(observation_noise_scale="x"), "observation_noise_scale"),
        (dict(incline_deg=45.0), "incline_deg"), (dict(incline_deg=-1.0), "incline_deg"), (dict(incline_deg=NAN), "incline_deg"),
        (dict(render_mode="x"), "render_mode"), (dict(record_replay="yes"), "record_replay"),
        (dict(render_size=(1, 1)), "render_size"), (dict(render_size="big"), "render_size"),
        (dict(render_size=(10**9, 10)), "render_size"),
        (dict(hydroelastic_pressure_step_kpa=-1.0), "hydroelastic_pressure_step_kpa"),
        (dict(hydroelastic_pressure_step_kpa=10.0), "hydroelastic_pressure_step_kpa"),
        (dict(bogus=1), "bogus"),
        (dict(omega_ref_range_rad_s=(8.0, 4.0)), "omega_ref_range_rad_s"),
        (dict(omega_ref_range_rad_s=(0.0, 1e9)), "omega_ref_range_rad_s"),
        (dict(omega_ref_range_rad_s="fast"), "omega_ref_range_rad_s"),
        (dict(reward_weights={"bogus": 1.0}), "reward_weights"), (dict(reward_weights={"speed": NAN}), "speed"),
        (dict(reward_weights="x"), "reward_weights"),
    ]
    if env_id.endswith("RampDescent-v0"):
        cases += [(dict(ramp_length_m=0.0), "ramp_length_m"), (dict(ramp_length_m=1e9), "ramp_length_m"),
                  (dict(ramp_length_m=None), "ramp_length_m"), (dict(lane_half_width_m=0.0), "lane_half_width_m"),
                  (dict(lane_half_width_m=100.0), "lane_half_width_m")]
    else:
        cases += [(dict(ramp_length_m=4.0), "ramp_length_m"), (dict(heading_range_rad=4.0), "heading_range_rad"),
                  (dict(heading_range_rad="x"), "heading_range_rad"), (dict(command_mode="x"), "command_mode"),
                  (dict(command_resample_s=0.0), "command_resample_s"), (dict(command_resample_s=-1.0), "command_resample_s"),
                  (dict(yaw_rate_range_rad_s=(1.0, -1.0)), "yaw_rate_range_rad_s")]
    return cases


def randomization_cases(env_id: str) -> list:
    """Randomization specs gym.make must refuse (the error names ``randomization``)."""
    sched = lambda rate, **kw: {"pressure_schedule": {"rate_kpa_per_s": rate, **kw}}  # noqa: E731
    cases = [
        "fully", 3, [1, 2], {"bogus": 1.0}, {"base": 3}, {"base": "fully"},
        {"pressure_kpa": 99.0}, {"pressure_kpa": [14.0, 3.0]}, {"pressure_kpa": NAN}, {"pressure_kpa": "high"},
        {"ground_friction": [0.5, 5.0]}, {"ground_friction": 0.0},
        {"ground_friction": {"distribution": "normal", "mean": 1.0, "std": -1.0}},
        {"ground_friction": {"distribution": "weird"}}, {"ground_friction": {"value": 1.0, "extra": 2}},
        {"ground_friction": {"low": 0.5, "high": 1.5, "mode": "interval"}},
        {"ground_friction": {"low": 0.5, "high": 1.5, "mode": "interval", "interval_s": -1.0}},
        {"ground_friction": {"low": 0.5, "high": 1.5, "mode": "sometimes"}},
        {"payload_mass_kg": {"distribution": "choice", "values": []}},
        {"payload_mass_kg": {"distribution": "choice", "values": 3}},
        {"payload_mass_kg": {"distribution": "uniform"}}, {"payload_mass_kg": [0.0, 1e6]},
        {"payload_com_offset_m": [1.0, 2.0]}, {"payload_com_offset_m": [[0, 0, 0], [1, 1, 1]]},
        {"steer_friction_scale": [1.0, 100.0]}, {"steer_friction_scale": {"distribution": "fixed", "value": NAN}},
        sched([0.1, -0.1]), sched({"distribution": "normal", "mean": 0.0, "std": -1.0}),
        sched({"distribution": "uniform"}), sched({"distribution": "choice", "values": []}), sched("fast"),
        sched(0.0, delay_s=-1.0), sched(NAN), {"pressure_schedule": {"rate": 1.0}}, {"pressure_schedule": 5},
    ]
    if env_id.endswith("Roll-v0"):
        cases.append({"incline_deg": [10.0, 20.0]})
    else:
        cases += [{"incline_deg": {"low": 10.0, "high": 20.0, "mode": "interval", "interval_s": 1.0}},
                  {"incline_deg": [10.0, 45.0]}]
    return cases


def option_cases(env_id: str) -> list[tuple[Any, str]]:
    """(options, field) for reset on a running episode. The first entry of a mapping is a valid
    change (pressure), so a reset that applied it before failing would be caught."""
    p = {"pressure_kpa": 12.0}
    cases = [
        ([("pressure_kpa", 12.0)], "options"), ("pressure_kpa=12", "options"), (3, "options"),
        ({**p, "bogus": 1}, "bogus"), ({"pressure_kpa": 99.0}, "pressure_kpa"), ({"pressure_kpa": NAN}, "pressure_kpa"),
        ({"pressure_kpa": "x"}, "pressure_kpa"), ({"pressure_kpa": [4.0, 8.0]}, "pressure_kpa"),
        ({**p, "ground_friction": 5.0}, "ground_friction"), ({**p, "payload_com_offset_m": [1.0]}, "payload_com_offset_m"),
        ({**p, "incline_deg": 45.0}, "incline_deg"), ({**p, "steer_friction_scale": 11.0}, "steer_friction_scale"),
        ({**p, "pressure_rate_kpa_per_s": "x"}, "pressure_rate_kpa_per_s"),
        ({**p, "pressure_rate_kpa_per_s": NAN}, "pressure_rate_kpa_per_s"),
        ({**p, "pressure_rate_kpa_per_s": [1.0]}, "pressure_rate_kpa_per_s"),
        ({**p, "initial_state": "upright"}, "initial_state"), ({**p, "initial_state": {"spin": 1.0}}, "initial_state"),
        ({**p, "initial_state": {"roll": NAN}}, "initial_state.roll"),
        ({**p, "initial_state": {"position_m": (0.0, 0.0, -0.5)}}, "initial_state.position_m"),
        ({**p, "initial_state": {"position_m": (0.0, 0.0)}}, "initial_state.position_m"),
        ({**p, "initial_state": {"velocity_m_s": "fast"}}, "initial_state.velocity_m_s"),
        ({**p, "initial_state": {"angular_velocity_rad_s": (0.0, 5e3, 0.0)}}, "initial_state.angular_velocity_rad_s"),
        ({**p, "initial_state": {"theta_dot": 1e300}}, "initial_state.theta_dot"),
        ({**p, "omega_ref": "abc"}, "omega_ref"), ({**p, "omega_ref": [1.0, 2.0]}, "omega_ref"),
        ({**p, "omega_ref": 1e9}, "omega_ref"), ({**p, "omega_ref": NAN}, "omega_ref"), ({**p, "omega_ref": None}, "omega_ref"),
    ]
    if env_id.endswith("Roll-v0"):
        cases += [({**p, "heading_ref": "x"}, "heading_ref"), ({**p, "heading_ref": 1e9}, "heading_ref"),
                  ({**p, "yaw_rate_ref": 1.0}, "yaw_rate_ref")]  # heading mode: yaw_rate_ref is not an option
    else:
        cases.append(({**p, "omega_ref": -1.0}, "omega_ref"))
    return cases


BAD_ACTIONS = [
    ("shape (3,)", np.zeros(3, np.float32)), ("shape (1,)", [0.1]), ("shape (2, 1)", np.zeros((2, 1))),
    ("scalar", 0.5), ("nested list", [[0.1, 0.2]]), ("str", "ab"), ("str list", ["0.1", "0.2"]),
    ("str array", np.array(["1", "0"])), ("complex", np.array([0.1 + 1j, 0.0])), ("None", None),
    ("None inside", [None, 0.1]), ("dict", {"steer": 0.1}), ("bool", [True, False]),
    ("object array", np.array([0.1, "x"], dtype=object)), ("NaN", np.array([NAN, 0.0], np.float32)),
    ("inf", [0.0, float("inf")]), ("float16 NaN", np.array([np.nan, 0], np.float16)),
]


def lockstep(env, ref, n: int = 3) -> bool:
    """Step both with the same actions; True if everything returned is identical."""
    rng = np.random.default_rng(0)
    for _ in range(n):
        a = rng.uniform(-1, 1, 2).astype(np.float32)
        o1, r1, te1, tr1, i1 = env.step(a)
        o2, r2, te2, tr2, i2 = ref.step(a)
        if not (np.array_equal(o1, o2) and r1 == r2 and i1["params"] == i2["params"] and i1.get("omega_ref") == i2.get("omega_ref")):
            return False
        if te1 or tr1:
            env.reset(seed=1)
            ref.reset(seed=1)
    return True


def fuzz_env_inputs(env_id: str, shell_model: str, tally: Tally) -> None:
    """Hostile kwargs, randomization specs, reset options, seeds and actions for one env × shell."""
    name = f"{env_id.split('/')[1]}/{shell_model}"
    for kw, field in kwarg_cases(env_id):
        tally.expect("make kwargs", f"{name} {kw}", lambda: gym.make(env_id, **{"shell_model": shell_model, **kw}), field)
    for spec in randomization_cases(env_id):
        tally.expect("randomization specs", f"{name} {spec}",
                     lambda: gym.make(env_id, shell_model=shell_model, randomization=spec), "randomization")
    env = gym.make(env_id, shell_model=shell_model, randomization="full", disable_env_checker=True)
    ref = gym.make(env_id, shell_model=shell_model, randomization="full", disable_env_checker=True)
    for e in (env, ref):
        e.reset(seed=0)

    def guarded(group, case, fn, field, exc=(ValueError,)):
        if not tally.expect(group, case, fn, field, exc):
            for e in (env, ref):  # resynchronize after a bug so the next case is judged alone
                e.reset(seed=0)
        elif not lockstep(env, ref):
            tally.counts[group]["clear_error"] -= 1
            tally.add(group, case, "half_written", "the episode changed")
            for e in (env, ref):
                e.reset(seed=0)

    for options, field in option_cases(env_id):
        guarded("reset options", f"{name} {options!r}", lambda: env.reset(options=options), field)
    for seed in (-1, 1.5, "7", True, [1, 2]):
        guarded("reset options", f"{name} seed={seed!r}", lambda: env.reset(seed=seed), "seed")
    for label, action in BAD_ACTIONS:
        guarded("action shapes/types", f"{name} {label}", lambda: env.step(action), "action")
    for e in (env, ref):
        e.close()


def _run_to_failure(env, action, max_steps: int, options=None) -> dict:
    env.reset(seed=0, options=options)
    a = np.asarray(action, np.float32)
    for i in range(1, max_steps + 1):
        obs, r, term, trunc, info = env.step(a)
        if term or trunc:
            return dict(steps=i, truncated=bool(trunc), terminated=bool(term),
                        reason=info.get("truncation_reason", ""), obs_finite=bool(np.all(np.isfinite(obs))))
    return dict(steps=max_steps, truncated=False, terminated=False, reason="(ran without failure)",
                obs_finite=bool(np.all(np.isfinite(obs))))


def fuzz_ended_and_copied(env_id: str, tally: Tally) -> list[dict]:
    """Drive real physics failures through the truncation path, then check that step() after the
    end of an episode, and on a copy made mid-episode, raises ``RuntimeError`` asking for a reset.
    Returns one row per failure attempt.

    Two routes: a robot launched at the largest accepted initial spin (499 rad/s per axis), and on
    flat ground an accepted drive friction just under the explicit-stability limit (viscous
    c = 120 N m s/rad at 5 ms, limit ≈123) run at full torque, where the explicit update can still
    diverge after tens of steps."""
    rows = []
    short = env_id.split("/")[1]
    for shell_model in SHELL_MODELS:
        env = gym.make(env_id, shell_model=shell_model, disable_env_checker=True)
        row = _run_to_failure(env, (0.0, 0.0), 5, {"initial_state": {"angular_velocity_rad_s": (499.0, 499.0, 499.0)}})
        rows.append(dict(env=short, shell_model=shell_model, route="initial spin 499 rad/s per axis", **row))
        if row["truncated"] or row["terminated"]:
            tally.expect("ended / copied episodes", f"{short}/{shell_model} step after the launched episode ended",
                         lambda: env.step(np.zeros(2, np.float32)), "call reset()", exc=(RuntimeError,))
        env.reset(seed=0)
        for _ in range(3):
            env.step(np.zeros(2, np.float32))
        for label, copier in (("deepcopy", copy.deepcopy), ("pickle", lambda e: pickle.loads(pickle.dumps(e)))):
            dup = copier(env)
            tally.expect("ended / copied episodes", f"{short}/{shell_model} step on a {label} made mid-episode",
                         lambda: dup.step(np.zeros(2, np.float32)), "call reset()", exc=(RuntimeError,))
            dup.close()
        env.close()
        if env_id.endswith("Roll-v0"):
            env = gym.make(env_id, shell_model=shell_model, randomization="off", disable_env_checker=True,
                           friction_model={"drive": {"law": "viscous", "params": {"c": 120.0}}})
            row = _run_to_failure(env, (-1.0, 1.0), 150 if shell_model == "hydroelastic" else 300)
            rows.append(dict(env=short, shell_model=shell_model, route="drive viscous c=120, full torque", **row))
            if row["truncated"]:
                tally.expect("ended / copied episodes", f"{short}/{shell_model} step after the diverged episode",
                             lambda: env.step(np.zeros(2, np.float32)), "call reset()", exc=(RuntimeError,))
            env.close()
    return rows


def fuzz_physics_limits(tally: Tally) -> None:
    """Configurations whose explicit torques diverge at the plant step, refused at gym.make."""
    import tempfile

    import yaml

    from sphere_env.resources import asset_path

    data = yaml.safe_load(asset_path("calibration", "default.yaml").read_text())
    with tempfile.TemporaryDirectory() as tmp:
        for wn in (250.0, 300.0, 1e4):
            data["omega_n"] = {**data["omega_n"], "intercept_rad_s": wn, "slope_rad_s_per_kpa": 0.0}
            path = os.path.join(tmp, f"omega_{wn:g}.yaml")
            with open(path, "w") as f:
                yaml.safe_dump(data, f)
            tally.expect("physics limits", f"injected omega_n={wn:g}",
                         lambda: gym.make("sphere_env/Roll-v0", shell_model="injected", calibration=path), "omega_n")
    tally.expect("physics limits", "coulomb friction with steer_friction_scale up to 10",
                 lambda: gym.make("sphere_env/Roll-v0", friction_model="coulomb", randomization={"steer_friction_scale": [1.0, 10.0]}),
                 "steer_friction_scale")
    env = gym.make("sphere_env/Roll-v0", friction_model="coulomb", disable_env_checker=True)
    env.reset(seed=0)
    tally.expect("physics limits", "coulomb friction, reset with steer_friction_scale=10",
                 lambda: env.reset(options={"steer_friction_scale": 10.0}), "steer_friction_scale")
    env.close()
    for c in (300.0, 1e3, 1e6):
        for joint in ("steer", "drive"):
            tally.expect("physics limits", f"viscous {joint} c={c:g}",
                         lambda: gym.make("sphere_env/Roll-v0", friction_model={joint: {"law": "viscous", "params": {"c": c}}}),
                         "friction_model")


def hostile_inputs() -> tuple[Tally, list[dict]]:
    tally = Tally()
    failures = []
    for env_id in ENV_IDS:
        for sm in SHELL_MODELS:
            fuzz_env_inputs(env_id, sm, tally)
        failures += fuzz_ended_and_copied(env_id, tally)
    fuzz_physics_limits(tally)
    return tally, failures


def _hostile_markdown(tally: Tally, failures: list[dict]) -> list[str]:
    from sphere_env.evaluation.reporting import markdown_table

    rows = tally.rows()
    total = rows[-1]
    cols = [("group", "inputs", ""), ("tried", "tried", "{}"), ("clear_error", "clear error", "{}"),
            ("other_exception", "other exception", "{}"), ("silent_acceptance", "silent acceptance", "{}"),
            ("half_written", "half-written", "{}")]
    fcols = [("env", "env", ""), ("shell_model", "shell", ""), ("route", "route", ""), ("steps", "steps", "{}"),
             ("truncated", "truncated", "{}"), ("reason", "info[\"truncation_reason\"]", ""),
             ("obs_finite", "obs finite", "{}")]
    md = [
        f"## Hostile inputs at the environment boundary: {total['tried']} tried, {total['clear_error']} clear errors, "
        f"{total['other_exception']} other exceptions, {total['silent_acceptance']} silently accepted, "
        f"{total['half_written']} half-written",
        "",
        "Every env id × shell model gets hostile `gym.make` kwargs, randomization specs (including pressure-schedule "
        "distributions), `reset` options and seeds on a running episode, and actions of wrong shape or type; plus "
        "step() after an episode ended and on a copy (deepcopy, pickle) made mid-episode, and configurations whose "
        "explicit torques diverge at the plant step. *Clear error*: the documented exception "
        "(`ValueError`; `RuntimeError` for step() without a valid episode) with a message naming the field. "
        "*Half-written*: the error came but the environment changed — after each refused reset or action the "
        "env and an identical twin env that never saw the input step on together and must return identical "
        "observations, rewards and parameters.",
        "",
        markdown_table(rows, cols),
        "",
    ]
    if tally.examples:
        md += ["Failures (first 40):", "", *[f"- `{e}`" for e in tally.examples], ""]
    md += [
        "### Physics failures through the truncation path",
        "",
        "Two routes: the largest accepted initial spin (499 rad/s about each axis), and on flat ground an accepted "
        "drive friction just under the explicit-stability limit (viscous c = 120 N m s/rad, limit ≈123 at 5 ms) at "
        "full torque, where the explicit friction update can still diverge. A failure must return `truncated=True` "
        "with the reason in `info` and a finite observation, and the next step() must ask for a reset (counted above).",
        "",
        markdown_table(failures, fcols),
        "",
    ]
    return md


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
            "n_epochs:1", "--env-kwargs", "shell_model:'point'"]
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
        (["--env-kwargs", "randomization:{'pressure_kpa': [14, 3]}"], "env_kwargs.randomization.pressure_kpa"),
        (["--env-kwargs", "randomization:{'pressure_kpa': {'distribution': 'uniform'}, "
                          "'pressure_schedule': {'rate_kpa_per_s': [0.5, -0.5]}}"], "env_kwargs.randomization"),
        (["--params", "randomization:'off'"], "hyperparams.randomization': a top-level key"),
        (["--params", "env_kwargs:[1, 2]"], "env_kwargs"), (["--env-kwargs", "shell_model:'jelly'"], "shell_model"),
        (["--params", "env_kwargs:{shell_model: jelly}"], "hyperparams.env_kwargs"),
        (["--params", "normalize:{'norm_ob': True}"], "normalize.norm_ob"), (["--algo", "dqn"], "algo"),
        (["--env", "sphere_env/Nope-v0"], "env"), (["--n-timesteps", "0"], "n_timesteps"),
        (["--n-timesteps", "nan"], "n_timesteps"), (["--eval-episodes", "0"], "eval_episodes"),
        (["--save-freq", "x"], "--save-freq"), (["--torch-threads", "0"], "torch_threads"),
        (["--seed", "x"], "--seed"), (["--eval-pressures-kpa", "2"], "eval_pressures_kpa"),
        (["-i", "missing.zip"], "trained_agent"),
        (["--resume", str(inputs / "broken_config_run"), "--n-timesteps", "nan"], "n_timesteps"),
        (["--algo", "sac", "--params", "ent_coef:auto_-1"], "hyperparams.ent_coef"),
        (["--algo", "sac", "--params", "train_freq:[1, hour]"], "hyperparams.train_freq"),
        (["--algo", "sac", "--params", "tau:0"], "hyperparams.tau"),
    ]
    def train_argv(argv, d):
        algo = argv[argv.index("--algo") + 1] if "--algo" in argv else "ppo"
        params = tiny[tiny.index("--params") + 1:tiny.index("--env-kwargs")] if algo == "ppo" else []
        extra = argv[argv.index("--params") + 1:] if "--params" in argv else []
        other = argv[:argv.index("--params")] if "--params" in argv else argv
        # the tiny env kwargs first: a case's own --env-kwargs are merged over them
        return ["--n-timesteps", "10", "--no-progress", *tiny[tiny.index("--env-kwargs"):], *other,
                *(["--params", *params, *extra] if params or extra else []), "--run-dir", str(d / "run")]

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
    grid = ["--replay", "--pressure-kpa", "8.5", "--shell-models", "point", "--seeds", "0", "--workers", "1"]
    a_file = _write(inputs / "a_file.txt", "not a folder\n")
    one_row = _write(inputs / "one_row_pme.csv", "t_s,omega_d\n0,1\n")
    eval_bad = [
        (["--controller", str(broken)], "model.zip"),
        (["--controller", "zero", "--env-kwargs", "{shell_model: point}"], "env_kwargs.shell_model"),
        (["--controller", "zero", "--env-kwargs", "{a: 1, a: 2}"], "env_kwargs"),
        (["--controller", "zero", "--env-kwargs", "{a: [1"], "env_kwargs"),
        (["--controller", "zero", "--env-kwargs", "[1, 2]"], "env_kwargs"),
        (["--controller", "zero", "--env-kwargs", "{no_such_kwarg: 1}"], "no_such_kwarg"),
        (["--controller", "sphere_env.evaluation.experiments.robustness:_bad_shape_controller"], "shape"),
        (["--controller", "no_such_module:f"], "controller"),
        (["--controller", str(run), "--env", "sphere_env/Roll-v0"], "--allow-env-mismatch"),
        (["--controller", "zero", "--pressure-kpa", "1000"], "pressure"),
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
    from sphere_env.evaluation.reporting import markdown_table

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


SOAK_COLUMNS = [
    ("env", "env", ""), ("shell_model", "shell", ""), ("steps", "steps", "{}"), ("wall_s", "wall s", "{:.0f}"),
    ("episodes", "episodes", "{}"), ("physics_failures", "physics failures", "{}"),
    ("twins_cached", "twins", "{}"), ("shells_cached", "hydroelastic shells cached", "{}"),
    ("rss_after_build_mb", "RSS built MB", "{:.1f}"), ("rss_first_sample_mb", "RSS 1st sample MB", "{:.1f}"),
    ("rss_end_mb", "RSS end MB", "{:.1f}"), ("growth_from_build_mb", "growth MB", "{:+.1f}"),
    ("growth_after_first_sample_mb", "growth after 1st sample MB", "{:+.1f}"),
    ("median_reset_ms", "median reset ms (warm)", "{:.2f}"), ("p95_reset_ms", "p95 reset ms (warm)", "{:.1f}"),
    ("median_reset_cpu_ms", "median reset CPU ms (warm)", "{:.2f}"),
    ("max_reset_ms", "max reset ms", "{:.0f}"),
]
SOAK_HEADING = "## Soak: every shell model, one process"


def run_soaks(soak_steps: int, hydroelastic_soak_steps: int) -> list[dict]:
    """The soaks: RampDescent with every shell model (hydroelastic for ``hydroelastic_soak_steps``),
    then Roll hydroelastic (a quarter of ``soak_steps``)."""
    soaks = []
    for sm in SHELL_MODELS:  # first, in fresh process heaps as far as possible
        n = hydroelastic_soak_steps if sm == "hydroelastic" else soak_steps
        soaks.append(soak(n, sample_every=max(n // 8, 1), shell_model=sm))
        print({k: v for k, v in soaks[-1].items() if k != "samples"}, flush=True)
    # Roll: one flat-ground twin, so the hydroelastic shell cache of a single twin alone.
    n = soak_steps // 4
    soaks.append(soak(n, sample_every=max(n // 8, 1), shell_model="hydroelastic", env_id="sphere_env/Roll-v0"))
    print({k: v for k, v in soaks[-1].items() if k != "samples"}, flush=True)
    return soaks


def soak_markdown(soaks: list[dict], command: str, commit: str, loads: tuple) -> list[str]:
    """The soak section of robustness.md (from its heading to the end of its RSS sample lines)."""
    from sphere_env.evaluation.reporting import markdown_table

    return [
        SOAK_HEADING,
        "",
        f"From `{command}` (commit {commit}; load average {loads[0][0]:.1f} at the start, {loads[1][0]:.1f} at "
        f"the end; wall-clock resets include waiting for a core, so their CPU time is given too). "
        f"`randomization=\"full\"` (every reset resamples pressure, friction, ground μ, payload, "
        f"incline on the ramp, leak), random actions. RSS = resident memory of this process; the soaks run one "
        f"after another, so later rows start from the heap the earlier ones left. Median and p95 reset over the "
        f"second half of the resets (caches warm). Limit {SOAK_LIMIT_MB:.0f} MB growth after build (hydroelastic "
        f"aim: 100 MB over 50,000 steps). A hydroelastic twin keeps up to {Twin.GEOMETRY_CACHE_SIZE} re-meshed "
        f"shells (one per 0.5 kPa grid pressure, ≈1.8 MB each); the hydroelastic env has one twin for every "
        f"incline the randomization draws (RampDescent's full randomization: 12–20°, snapped to 1°), which moves "
        f"its ground between episodes, so its shells serve every incline: hydroelastic growth is bounded by one "
        f"twin's cache, ≈45 MB. Point and injected keep one twin per incline (nothing cached).",
        "",
        markdown_table(soaks, SOAK_COLUMNS),
        "",
        *[f"- {s['env']} {s['shell_model']} RSS samples (step, MB): "
          f"{', '.join(f'({i}, {m:.1f})' for i, m in s['samples'])}" for s in soaks],
    ]


def _replace_soak_section(md: str, section: list[str]) -> str:
    """``md`` with its soak section (heading up to the next ``## ``) replaced by ``section``."""
    lines = md.splitlines()
    try:
        i = lines.index(SOAK_HEADING)
    except ValueError:
        raise ValueError(f"robustness.md: no {SOAK_HEADING!r} section to replace; run without --soak-only") from None
    j = next((k for k in range(i + 1, len(lines)) if lines[k].startswith("## ")), len(lines))
    return "\n".join(lines[:i] + section + [""] + lines[j:]).rstrip("\n") + "\n"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--fuzz-steps", type=int, default=60_000,
                        help="total fuzzed step() calls over all cases (~25%% are NaN/inf and raise)")
    parser.add_argument("--soak-steps", type=int, default=40_000,
                        help="soak steps for point and injected (Roll hydroelastic: a quarter)")
    parser.add_argument("--hydroelastic-soak-steps", type=int, default=None,
                        help="RampDescent hydroelastic soak steps (default: a quarter of --soak-steps; "
                             "hydroelastic is ~5x slower per step)")
    parser.add_argument("--soak-only", action="store_true",
                        help="run only the soaks and replace the soak section of the existing results "
                             "(robustness.md section, robustness.json 'soak'); the rest is kept")
    args = parser.parse_args(argv)
    hydro_steps = args.soak_steps // 4 if args.hydroelastic_soak_steps is None else args.hydroelastic_soak_steps
    if min(args.soak_steps, hydro_steps, args.fuzz_steps) < 8:
        parser.error("--soak-steps, --hydroelastic-soak-steps and --fuzz-steps must be at least 8")
    from sphere_env.evaluation.reporting import RESULTS, machine_info, markdown_table

    info = machine_info()  # at the start: the commit that is actually run
    load0 = os.getloadavg()
    soak_cmd = (f"python -m evaluation.experiments.robustness --soak-steps {args.soak_steps} "
                f"--hydroelastic-soak-steps {hydro_steps}")
    if args.soak_only:
        md_path, json_path = RESULTS / "robustness.md", RESULTS / "robustness.json"
        old_md = md_path.read_text()  # both read before the long run: fail early
        _replace_soak_section(old_md, [])
        out = json.loads(json_path.read_text())
        soaks = run_soaks(args.soak_steps, hydro_steps)
        section = soak_markdown(soaks, soak_cmd + " --soak-only", info["commit"], (load0, os.getloadavg()))
        out["soak"] = soaks
        out["soak_machine"] = info
        write_text_atomic(json_path, json.dumps(out, indent=2))
        write_text_atomic(md_path, _replace_soak_section(old_md, section))
        print("\n".join(section))
        return
    soaks = run_soaks(args.soak_steps, hydro_steps)
    load_soak = os.getloadavg()
    tally, failures = hostile_inputs()
    print(tally.rows()[-1], flush=True)
    interfaces = fuzz_interfaces()
    # Hydroelastic is ~5x slower per step: give it a third of the point/injected share.
    weights = {"point": 3, "injected": 3, "hydroelastic": 1}
    total_w = sum(weights.values()) * len(ENV_IDS)
    rows = []
    for env_id in ENV_IDS:
        for sm in SHELL_MODELS:
            n = int(np.ceil(args.fuzz_steps * weights[sm] / total_w))
            rows.append(fuzz(env_id, sm, n))
            print(rows[-1], flush=True)
    load1 = os.getloadavg()
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
        f"by `python -m evaluation.experiments.robustness --fuzz-steps {args.fuzz_steps} --soak-steps {args.soak_steps} "
        f"--hydroelastic-soak-steps {hydro_steps}` "
        f"(commit {info['commit']}); {info['cpu']}, {info['cores']} cores, shared with other jobs "
        f"(load average {load0[0]:.1f} at the start, {load1[0]:.1f} at the end).",
        "",
        *_hostile_markdown(tally, failures),
        f"## Fuzzed actions: {fuzz_total} step() calls ({fuzz_advanced} simulated), {unexpected} unexpected exceptions",
        "",
        "Actions: 40% uniform [-1, 1], 20% ±1e6, 15% N(0, 1e6²), 12.5% with a NaN, 12.5% with ±inf; "
        "`randomization=\"full\"`. NaN/inf must raise `ValueError` naming the action (and the env stays usable); "
        "everything else is clipped and stepped (so these never reach the truncation path: see above).",
        "",
        markdown_table(rows, cols),
        "",
        *soak_markdown(soaks, f"python -m evaluation.experiments.robustness --fuzz-steps {args.fuzz_steps} --soak-steps "
                              f"{args.soak_steps} --hydroelastic-soak-steps {hydro_steps}", info["commit"], (load0, load_soak)),
    ]
    md += [""] + interfaces_markdown(interfaces)
    out = {"machine": info, "load_average": [load0, load1], "hostile_inputs": tally.rows(),
           "hostile_examples": tally.examples, "physics_failures": failures, "fuzz": rows, "soak": soaks,
           "interfaces": interfaces}
    RESULTS.mkdir(parents=True, exist_ok=True)
    # Temp names then rename: an interrupted run leaves the previous results whole.
    for name, text in (("robustness.md", "\n".join(md) + "\n"), ("robustness.json", json.dumps(out, indent=2))):
        write_text_atomic(RESULTS / name, text)
    print("\n".join(md))


if __name__ == "__main__":
    main()
