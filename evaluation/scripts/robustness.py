"""Robustness of the Gymnasium environments: action fuzzing and a memory soak.

* **Fuzz**: every env id × shell model, actions drawn from a mixture — uniform in [-1, 1], ±1e6,
  1e6-scale Gaussian, and vectors containing NaN or ±inf. NaN/inf must raise ``ValueError``
  (documented); everything else must step. No other exception may escape, observations must
  stay finite, and episodes end only by termination, time limit or a reported physics failure.
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
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "robustness.md").write_text("\n".join(md) + "\n")
    (RESULTS / "robustness.json").write_text(json.dumps({"machine": info, "fuzz": rows, "soak": s}, indent=2))
    print("\n".join(md))


if __name__ == "__main__":
    main()
