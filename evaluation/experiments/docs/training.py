"""Blocks of ``docs/results/training_speed.md``: ``benchmark_train.json``."""

from __future__ import annotations

from sphere_env.evaluation.experiments.docs.base import (
    Results,
    cpu,
    fixed2,
    ratios,
    renders,
    signed,
    span,
    table,
    train_row,
    whole,
)
from sphere_env.evaluation.experiments.docs.speed import AIM_ROLLOUT_PCT, AIM_TRAIN_PCT
from sphere_env.evaluation.experiments.train_cases import ROLLOUT


def _train(res: Results) -> dict:
    return res.json("benchmark_train.json")


def _both(res: Results, layout: str, cores: int | None = None) -> list[dict]:
    t = _train(res)
    return [train_row(t, s, layout, t["train"]["cores"] if cores is None else cores) for s in ("point", "injected")]


@renders("train_blocks_vs_threads")
def train_blocks_vs_threads(res: Results) -> str:
    ship, thr = _both(res, "shipped"), _both(res, "thread8")
    return " and ".join(
        f"{a['train_steps_per_s'] / b['train_steps_per_s']:.2f}× ({a['shell_model']})" for a, b in zip(ship, thr)
    )


@renders("train_run")
def train_run(res: Results) -> str:
    t = _train(res)
    m, tr = t["machine"], t["train"]
    return (
        f"at commit {m['commit']} ({cpu(m['cpu'])}, {m['cores']} cores, 1-min load average "
        f"{tr['load_avg_start'][0]:.1f} → {tr['load_avg_end'][0]:.1f}), every case timed in {tr['rounds']} "
        f"interleaved rounds × {tr['seconds_per_case'] / tr['rounds']:g} s"
    )


LAYOUT_LABELS = {  # (layout, cores) in benchmark_train.json -> the row's label on the page
    ("single", 1): "single env (one core)",
    ("shipped", 2): "**shipped: {n_envs} envs × {n_steps} steps in {cores} blocks** (`n_workers: auto`)",
    ("shipped", 1): "shipped, pinned to one core",
    ("thread8", 2): "former default: {n_envs} envs × {n_steps}, {n_threads} threads",
    ("thread2", 2): "{n_envs} envs × {n_steps}, {n_threads} threads",
    ("subproc2", 2): "{n_envs} envs × {n_steps}, 1 process each",
    ("proc16", 2): "{n_envs} envs × {n_steps} in {n_workers} blocks",
    ("thread16", 2): "{n_envs} envs × {n_steps}, {n_threads} threads",
}


@renders("train_table")
def train_table(res: Results) -> str:
    rows_in = _train(res)["train"]["rows"]
    shells = list(dict.fromkeys(r["shell_model"] for r in rows_in))
    rows = []
    for (layout, cores), label in LAYOUT_LABELS.items():
        own = {r["shell_model"]: r for r in rows_in if r["layout"] == layout and r["cores"] == cores}
        if not own:
            continue
        first = next(iter(own.values()))
        row = [label.format(**first), str(cores)]
        bold = label.startswith("**")
        for s in shells:
            r = own.get(s)
            if r is None:
                row += [""] * 5
            elif layout == "single":
                row += [whole(r["single_env_steps_per_s"]) + (" env steps/s" if s == shells[0] else ""), "", "", "", ""]
            else:
                cells = [
                    whole(r["rollout_steps_per_s"]),
                    f"{r['rollout_ratio_pct']:.0f}%",
                    f"{r['stepping_ratio_pct']:.0f}%",
                    whole(r["train_steps_per_s"]),
                    f"{r['train_ratio_pct']:.0f}%",
                ]
                row += [f"**{c}**" if bold and i != 2 else c for i, c in enumerate(cells)]
        rows.append(row)
    head = [f"layout ({ROLLOUT} samples per update)", "cores"]
    for s in shells:
        head += [f"{s}: rollout", "ratio", "stepping alone", "training", "ratio"]
    return table(head, rows)


@renders("train_16_vs_8")
def train_16_vs_8(res: Results) -> str:
    a, b = _both(res, "proc16")[0], _both(res, "shipped")[0]
    return f"{signed(100 * (a['train_steps_per_s'] / b['train_steps_per_s'] - 1), 0)}% training"


@renders("train_main_ms")
def train_main_ms(res: Results) -> str:
    return f"{span((r['main_ms_per_vec_step'] for r in _both(res, 'shipped')), fixed2)} ms"


@renders("train_aims")
def train_aims(res: Results) -> str:
    ship = _both(res, "shipped")
    t = _train(res)["train"]
    two = [r for r in t["rows"] if r["cores"] == t["cores"] and r["layout"] != "single"]
    best = max(two, key=lambda r: r["train_ratio_pct"])
    best_both = _both(res, best["layout"])

    def verdict(key: str, aim: float) -> str:
        return "met" if min(r[key] for r in ship) >= aim else "missed"

    return (
        f"On the current machine the shipped layout trains at **{ship[0]['train_ratio_pct']:.0f}% (point) and "
        f"{ship[1]['train_ratio_pct']:.0f}% (injected): {verdict('train_ratio_pct', AIM_TRAIN_PCT)}**, and "
        "collects "
        f"rollouts at **{ratios(ship, 'rollout_ratio_pct').replace(' / ', ' and ')}: "
        f"{verdict('rollout_ratio_pct', AIM_ROLLOUT_PCT)}**. The fastest layout measured, "
        f"{LAYOUT_LABELS[(best['layout'], t['cores'])].format(**best).strip('*')}, reaches "
        f"{ratios(best_both, 'train_ratio_pct')} training and {ratios(best_both, 'rollout_ratio_pct')} rollouts "
        f"(segments of {best['n_steps']} steps)"
    )


@renders("train_stepping")
def train_stepping(res: Results) -> str:
    ship, pinned = _both(res, "shipped"), _both(res, "shipped", 1)
    m = _train(res)["train"]["model"]
    return (
        f"stepping alone {ratios(ship, 'stepping_ratio_pct')} (point / injected) of two single envs; an env step "
        f"inside a block e_b = {m['point']['env_ms_per_step_in_block']:.2f} ms (point) against "
        f"{m['point']['env_ms_per_step_single']:.2f} ms for the single env stepped in a loop; pinned to one core, "
        f"the same layout's stepping {ratios(pinned, 'stepping_ratio_pct')} of one single env"
    )


@renders("train_main_share")
def train_main_share(res: Results) -> str:
    r = _both(res, "shipped")[0]
    return (
        f"c = {r['main_ms_per_vec_step']:.2f} ms per vectorized step (point); shared by {r['n_envs']} envs "
        f"{r['main_ms_per_vec_step'] / r['n_envs']:.2f} ms per env step: "
        f"{r['stepping_ratio_pct'] - r['rollout_ratio_pct']:.0f} points of the ratio (stepping alone "
        f"{r['stepping_ratio_pct']:.0f}%, rollouts {r['rollout_ratio_pct']:.0f}%)"
    )


@renders("train_update_share")
def train_update_share(res: Results) -> str:
    return f"{span((r['update_share_pct'] for r in _both(res, 'shipped')), lambda x: f'{x:.0f}')}%"


@renders("train_scaling")
def train_scaling(res: Results) -> str:
    ship, pinned = _both(res, "shipped"), _both(res, "shipped", 1)
    return ", ".join(
        f"{whole(p['train_steps_per_s'])} → {whole(s['train_steps_per_s'])} env steps/s "
        f"({s['shell_model']}, ×{s['train_steps_per_s'] / p['train_steps_per_s']:.2f})"
        for p, s in zip(pinned, ship)
    )


@renders("train_model")
def train_model(res: Results) -> str:
    m = _train(res)["train"]["model"]
    p, i = m["point"], m["injected"]
    return (
        f"for point contact, u = {p['update_ms_per_step']:.3f} ms, c0 = {p['main_ms_per_vec_step_fixed']:.2f} ms, "
        f"c1 = {p['main_ms_per_env_per_vec_step']:.3f} ms, e_b = {p['env_ms_per_step_in_block']:.3f} ms (injected: "
        f"u = {i['update_ms_per_step']:.3f}, c0 = {i['main_ms_per_vec_step_fixed']:.2f}, "
        f"c1 = {i['main_ms_per_env_per_vec_step']:.3f}, e_b = {i['env_ms_per_step_in_block']:.3f})"
    )


@renders("train_prediction")
def train_prediction(res: Results) -> str:
    p = _train(res)["train"]["model"]["point"]
    cores = list(p["predicted_shipped"])
    return table(
        ["cores N (point)", *cores],
        [
            [
                f"shipped ({p['n_envs']} envs), predicted training env steps/s",
                *(whole(p["predicted_shipped"][c]) for c in cores),
            ],
            ["one env per core (n = N), predicted", *(whole(p["predicted_one_env_per_core"][c]) for c in cores)],
        ],
    )


@renders("train_prediction_measured")
def train_prediction_measured(res: Results) -> str:
    p = _train(res)["train"]["model"]["point"]
    return f"measured at 1 and 2 cores: {whole(p['measured_1_core'])} and {whole(p['measured_2_cores'])}"


@renders("train_ceiling")
def train_ceiling(res: Results) -> str:
    p = _train(res)["train"]["model"]["point"]
    top = max(p["predicted_shipped"].values())
    return f"≈ {top / 1e3:.1f} k env steps/s from {p['n_envs']} cores on"


@renders("train_many_cores")
def train_many_cores(res: Results) -> str:
    p = _train(res)["train"]["model"]["point"]
    n = max(p["predicted_one_env_per_core"], key=int)
    return (
        f"with {n} envs on {n} cores the model gives ≈ {p['predicted_one_env_per_core'][n] / 1e3:.1f} k env "
        "steps/s, "
        f"of which the PPO update alone caps training at 1 / u ≈ {1 / p['update_ms_per_step']:.0f} k steps/s"
    )
