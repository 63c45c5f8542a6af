"""Robustness benchmark of the Gymnasium environments: action fuzzing and memory soaks.

* **Action fuzz** (:func:`fuzz`): actions from a mixture — uniform in [-1, 1], ±1e6, 1e6-scale
  Gaussian, vectors containing NaN or ±inf. NaN/inf must raise ``ValueError`` (documented);
  everything else is clipped and stepped; observations must stay finite.
* **Soak** (:func:`soak`): one env per shell model (RampDescent-v0, ``randomization="full"``),
  random actions; resident memory (RSS) sampled along the way, resets timed.

Hostile inputs (bad kwargs, randomization specs, reset options, seeds and actions; ended and copied
episodes; diverging configurations; hostile command lines, calibration files and logs) are not
benchmarked here: they are pytest cases in ``tests/hostile/``, run by ``make test``.

Writes ``evaluation/results/robustness.md`` and ``.json`` (temp name, then renamed).

    python -m evaluation.experiments.robustness [--fuzz-steps 60000] [--soak-steps 40000] [--hydroelastic-soak-steps N]
    python -m evaluation.experiments.robustness --soak-only ...   # replace only the soak results
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
from sphere_env.files import write_text_atomic
from sphere_env.params import SHELL_MODELS
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
            ends[
                "physics_failure"
                if reason
                else ("success" if info.get("is_success") else ("terminated" if term else "time_limit"))
            ] += 1
            env.reset()
    wall = time.perf_counter() - t0
    env.close()
    return dict(
        env=env_id.split("/")[1],
        shell_model=shell_model,
        steps=steps,
        advanced=steps - counts["raised_as_documented"],
        wall_s=wall,
        nan_inf_raised=counts["raised_as_documented"],
        nan_inf_sent=counts["nan"] + counts["inf"],
        huge_sent=counts["pm1e6"] + counts["gauss1e6"],
        episodes=sum(ends.values()),
        physics_failures=ends["physics_failure"],
        success=ends["success"],
        non_finite_outputs=bad_obs,
        unexpected=len(unexpected),
        unexpected_examples=unexpected[:5],
    )


def soak(
    steps: int,
    seed: int = 0,
    sample_every: int = 10_000,
    shell_model: str = "injected",
    env_id: str = "sphere_env/RampDescent-v0",
) -> dict:
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
    late = sorted(reset_s[len(reset_s) // 2 :]) or [float("nan")]
    late_cpu = reset_cpu_s[len(reset_cpu_s) // 2 :] or [float("nan")]
    return dict(
        env=env_id.split("/")[1],
        shell_model=shell_model,
        steps=steps,
        wall_s=wall,
        steps_per_s=steps / wall,
        episodes=episodes,
        physics_failures=failures,
        twins_cached=twins,
        shells_cached=shells,
        rss_start_mb=rss0,
        rss_after_build_mb=rss_built,
        rss_first_sample_mb=warm,
        rss_end_mb=samples[-1][1],
        growth_from_build_mb=samples[-1][1] - rss_built,
        growth_after_first_sample_mb=samples[-1][1] - warm,
        samples=samples,
        median_reset_ms=1e3 * float(np.median(late)),
        p95_reset_ms=1e3 * float(np.percentile(late, 95)),
        median_reset_cpu_ms=1e3 * float(np.median(late_cpu)),
        max_reset_ms=1e3 * max(reset_s, default=float("nan")),
        ok=samples[-1][1] - rss_built <= SOAK_LIMIT_MB,
    )


HOSTILE_NOTE = (
    "Hostile inputs (bad kwargs, randomization specs, reset options, seeds and actions; ended and "
    "copied episodes; diverging configurations; hostile command lines, calibration files and logs) "
    "are pytest cases in `tests/hostile/`, run by `make test`."
)

SOAK_COLUMNS = [
    ("env", "env", ""),
    ("shell_model", "shell", ""),
    ("steps", "steps", "{}"),
    ("wall_s", "wall s", "{:.0f}"),
    ("episodes", "episodes", "{}"),
    ("physics_failures", "physics failures", "{}"),
    ("twins_cached", "twins", "{}"),
    ("shells_cached", "hydroelastic shells cached", "{}"),
    ("rss_after_build_mb", "RSS built MB", "{:.1f}"),
    ("rss_first_sample_mb", "RSS 1st sample MB", "{:.1f}"),
    ("rss_end_mb", "RSS end MB", "{:.1f}"),
    ("growth_from_build_mb", "growth MB", "{:+.1f}"),
    ("growth_after_first_sample_mb", "growth after 1st sample MB", "{:+.1f}"),
    ("median_reset_ms", "median reset ms (warm)", "{:.2f}"),
    ("p95_reset_ms", "p95 reset ms (warm)", "{:.1f}"),
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
    from sphere_env.reporting import markdown_table

    return [
        SOAK_HEADING,
        "",
        f"From `{command}` (commit {commit}; load average {loads[0][0]:.1f} at the start, {loads[1][0]:.1f} at "
        f"the end; wall-clock resets include waiting for a core, so their CPU time is given too). "
        f'`randomization="full"` (every reset resamples pressure, friction, ground μ, payload, '
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
        *[
            f"- {s['env']} {s['shell_model']} RSS samples (step, MB): "
            f"{', '.join(f'({i}, {m:.1f})' for i, m in s['samples'])}"
            for s in soaks
        ],
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
    parser.add_argument(
        "--fuzz-steps",
        type=int,
        default=60_000,
        help="total fuzzed step() calls over all cases (~25%% are NaN/inf and raise)",
    )
    parser.add_argument(
        "--soak-steps",
        type=int,
        default=40_000,
        help="soak steps for point and injected (Roll hydroelastic: a quarter)",
    )
    parser.add_argument(
        "--hydroelastic-soak-steps",
        type=int,
        default=None,
        help="RampDescent hydroelastic soak steps (default: a quarter of --soak-steps; "
        "hydroelastic is ~5x slower per step)",
    )
    parser.add_argument(
        "--soak-only",
        action="store_true",
        help="run only the soaks and replace the soak section of the existing results "
        "(robustness.md section, robustness.json 'soak'); the rest is kept",
    )
    args = parser.parse_args(argv)
    hydro_steps = args.soak_steps // 4 if args.hydroelastic_soak_steps is None else args.hydroelastic_soak_steps
    if min(args.soak_steps, hydro_steps, args.fuzz_steps) < 8:
        parser.error("--soak-steps, --hydroelastic-soak-steps and --fuzz-steps must be at least 8")
    from sphere_env.evaluation.experiments import RESULTS
    from sphere_env.provenance import machine_info
    from sphere_env.reporting import markdown_table

    info = machine_info()  # at the start: the commit that is actually run
    load0 = os.getloadavg()
    soak_cmd = (
        f"python -m evaluation.experiments.robustness --soak-steps {args.soak_steps} "
        f"--hydroelastic-soak-steps {hydro_steps}"
    )
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
    cols = [
        ("env", "env", ""),
        ("shell_model", "shell", ""),
        ("steps", "step() calls", "{}"),
        ("advanced", "steps simulated", "{}"),
        ("wall_s", "wall s", "{:.0f}"),
        ("huge_sent", "±1e6 / 1e6σ actions", "{}"),
        ("nan_inf_sent", "NaN/inf actions", "{}"),
        ("nan_inf_raised", "…raised ValueError", "{}"),
        ("episodes", "episodes", "{}"),
        ("physics_failures", "physics-failure truncations", "{}"),
        ("non_finite_outputs", "non-finite obs/reward", "{}"),
        ("unexpected", "unexpected exceptions", "{}"),
    ]
    md = [
        "# sphere_env robustness",
        "",
        f"Generated {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC "
        f"by `python -m evaluation.experiments.robustness --fuzz-steps {args.fuzz_steps} --soak-steps {args.soak_steps} "
        f"--hydroelastic-soak-steps {hydro_steps}` "
        f"(commit {info['commit']}); {info['cpu']}, {info['cores']} cores, shared with other jobs "
        f"(load average {load0[0]:.1f} at the start, {load1[0]:.1f} at the end).",
        "",
        HOSTILE_NOTE,
        "",
        f"## Fuzzed actions: {fuzz_total} step() calls ({fuzz_advanced} simulated), {unexpected} unexpected exceptions",
        "",
        "Actions: 40% uniform [-1, 1], 20% ±1e6, 15% N(0, 1e6²), 12.5% with a NaN, 12.5% with ±inf; "
        '`randomization="full"`. NaN/inf must raise `ValueError` naming the action (and the env stays usable); '
        "everything else is clipped and stepped (so these never reach the truncation path).",
        "",
        markdown_table(rows, cols),
        "",
        *soak_markdown(
            soaks,
            f"python -m evaluation.experiments.robustness --fuzz-steps {args.fuzz_steps} --soak-steps "
            f"{args.soak_steps} --hydroelastic-soak-steps {hydro_steps}",
            info["commit"],
            (load0, load_soak),
        ),
    ]
    out = {"machine": info, "load_average": [load0, load1], "fuzz": rows, "soak": soaks}
    RESULTS.mkdir(parents=True, exist_ok=True)
    # Temp names then rename: an interrupted run leaves the previous results whole.
    for name, text in (("robustness.md", "\n".join(md) + "\n"), ("robustness.json", json.dumps(out, indent=2))):
        write_text_atomic(RESULTS / name, text)
    print("\n".join(md))


if __name__ == "__main__":
    main()
