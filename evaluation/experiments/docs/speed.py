"""Blocks of the speed pages (README and ``docs/results/speed.md``): ``benchmark.json``,
``benchmark_train.json`` and ``hydro_tradeoff.json``."""

from __future__ import annotations

from sphere_env.evaluation.experiments.benchmark_env import AIM_OVERHEAD_PCT, AIM_RESET_MS, AIM_STEPS_PER_S
from sphere_env.evaluation.experiments.docs.base import (
    Results,
    cpu,
    fixed,
    fixed2,
    kpa,
    ratios,
    renders,
    signed,
    slash,
    span,
    table,
    train_row,
    whole,
)
from sphere_env.evaluation.experiments.train_cases import ENV_ID

#: Aims (requirements, not measurements) of the twin and the training benchmarks.
AIM_TWIN_RTF = {"point": 40.0, "injected": 35.0, "hydroelastic": 12.0}
AIM_TWIN_OVERHEAD_PCT = 20.0
AIM_TRAIN_PCT, AIM_ROLLOUT_PCT = 50.0, 80.0


def hydro(res: Results) -> dict:
    return res.json("hydro_tradeoff.json")


HYDRO_SHIPPED = "0.05 m, 5 ms (shipped)"
HYDRO_FAST = "opt-in hydroelastic_fast.yaml at time_step_s=0.01: low-pressure mesh, k_d(p) fitted to ζ(p)"
HYDRO_LOW_MESH_10MS = "opt-in low-pressure mesh at time_step_s=0.01, shipped k_d_by_time_step"
HYDRO_LOW_MESH = "opt-in low-pressure mesh: 0.1 m below 5 kPa else 0.05 m, 5 ms"
HYDRO_UNIFORM_COARSE = "0.1 m, 5 ms"
#: hydro_tradeoff.json's candidates in the speed page's table, with their labels there.
HYDRO_ROWS = {
    HYDRO_SHIPPED: "0.05 m mesh, 5 ms (shipped)",
    HYDRO_LOW_MESH: "opt-in low-pressure mesh: 0.1 m below 5 kPa, 5 ms",
    HYDRO_LOW_MESH_10MS: "low-pressure mesh with `time_step_s=0.01` (the calibration's single 10 ms k_d)",
    HYDRO_FAST: '**`calibration="hydroelastic_fast"`, `time_step_s=0.01`**: low-pressure mesh, k_d(p) fitted to ζ(p)',
}


@renders("benchmark_run")
def benchmark_run(res: Results) -> str:
    m = res.json("benchmark.json")["machine"]
    return f"commit {m['commit']}, {cpu(m['cpu'])}, {m['cores']} cores"


@renders("speed_table")
def speed_table(res: Results) -> str:
    b, t, h = res.json("benchmark.json"), res.json("benchmark_train.json"), hydro(res)
    twin = {r["shell_model"]: r for r in b["twin"] if r["friction"] != "none"}
    shells = list(twin)

    def aim_rtf(s: str) -> str:
        return f"≥ {AIM_TWIN_RTF[s]:g}×" + ("" if twin[s]["rtf"] >= AIM_TWIN_RTF[s] else " (missed)")

    aim, fast = AIM_TWIN_RTF["hydroelastic"], h["speed"][HYDRO_FAST]["mean_rtf"]
    hydro_aim = (
        f"≥ {aim:g}× ({'met' if twin['hydroelastic']['rtf'] >= aim else 'missed'} by the shipped setting; "
        f"`hydroelastic_fast` {'meets' if fast >= aim else 'misses'} it: {fast:.1f}× mean over "
        f"{kpa(min(h['pressures_kpa']))}–{kpa(max(h['pressures_kpa']))} kPa)"
    )
    over = [twin[s]["overhead_pct"] for s in shells]
    rows = [
        [
            "twin, 10 s down the 16° ramp in 20 ms chunks, Majd on both joints: point",
            f"**{twin['point']['rtf']:.1f}×** real time ({whole(twin['point']['chunks_per_s'])} chunks/s)",
            aim_rtf("point"),
        ],
        ["… injected", f"**{twin['injected']['rtf']:.1f}×**", aim_rtf("injected")],
        ["… hydroelastic (0.05 m mesh)", f"{twin['hydroelastic']['rtf']:.1f}×", hydro_aim],
        [
            f"… overhead over the bare plant, same trajectory: {slash(shells)}",
            f"**{slash(over, lambda o: signed(o) + '%')}**",
            f"≤ {AIM_TWIN_OVERHEAD_PCT:g}%" + ("" if max(over) <= AIM_TWIN_OVERHEAD_PCT else " (missed)"),
        ],
    ]
    envs = b["env"]
    for env_id in dict.fromkeys(r["env"] for r in envs):
        own = {r["shell_model"]: r for r in envs if r["env"] == env_id}
        missed = [s for s, r in own.items() if r["env_steps_per_s"] < AIM_STEPS_PER_S[s]]
        name, version = env_id.rsplit("-", 1)
        aims = slash(own, lambda s: whole(AIM_STEPS_PER_S[s])) + (f" (missed: {', '.join(missed)})" if missed else "")
        rows.append(
            [
                f"env steps/s at 50 Hz, {name} (-{version}): {slash(own)}",
                slash(own.values(), lambda r: whole(r["env_steps_per_s"])),
                aims,
            ]
        )
    env_over = [r["overhead_pct"] for r in envs]
    rows.append(
        [
            "env overhead over the bare twin, same trajectory",
            f"**{signed(min(env_over))}% … {signed(max(env_over))}%**",
            f"≤ {AIM_OVERHEAD_PCT:g}%" + ("" if max(env_over) <= AIM_OVERHEAD_PCT else " (missed)"),
        ]
    )
    resets = [r["reset_ms"] for r in envs]
    rigid = span((r["reset_ms"] for r in envs if r["shell_model"] != "hydroelastic"), fixed2)
    soft = span((r["reset_ms"] for r in envs if r["shell_model"] == "hydroelastic"), fixed2)
    rows.append(
        [
            "`reset()`",
            f"{rigid} ms (hydroelastic {soft} ms with a cached shell)",
            f"≤ {AIM_RESET_MS:g} ms" + ("" if max(resets) <= AIM_RESET_MS else " (missed)"),
        ]
    )
    rows += _train_speed_rows(t)
    return table(["what", "measured (last run)", "aim"], rows)


def _scaling(pair: tuple[dict, dict]) -> str:
    one, two = (r["train_steps_per_s"] for r in pair)
    return f"{whole(one)} → {whole(two)} (×{two / one:.2f})"


def _train_speed_rows(t: dict) -> list[list[str]]:
    m, tr = t["machine"], t["train"]
    cores, pair = tr["cores"], ("point", "injected")
    ship = [train_row(t, s, "shipped", cores) for s in pair]
    pinned = [train_row(t, s, "shipped", 1) for s in pair]
    thread8 = [train_row(t, s, "thread8", cores) for s in pair]
    blocks_n = min(cores, ship[0]["n_envs"])
    env_name = ENV_ID.split("/")[-1]
    train_ok = min(r["train_ratio_pct"] for r in ship) >= AIM_TRAIN_PCT
    roll_ok = min(r["rollout_ratio_pct"] for r in ship) >= AIM_ROLLOUT_PCT
    workers = blocks_n - 1
    return [
        [
            f"PPO training, shipped config ({ship[0]['n_envs']} envs × {ship[0]['n_steps']} in {blocks_n} blocks: "
            f"training process + {workers} worker{'s' if workers != 1 else ''}), `{env_name}`, point / injected "
            f"(`benchmark_train.md`, commit {m['commit']}, {cpu(m['cpu'])} {m['cores']} cores, load "
            f"{tr['load_avg_start'][0]:.1f}–{tr['load_avg_end'][0]:.1f})",
            f"**{slash(ship, lambda r: whole(r['train_steps_per_s']))} env steps/s** = "
            f"{ratios(ship, 'train_ratio_pct')} of {cores} × single-env rate",
            f"≥ {AIM_TRAIN_PCT:g}%" + ("" if train_ok else " (missed)"),
        ],
        [
            "PPO rollout collection, shipped config, point / injected (same run)",
            f"{slash(ship, lambda r: whole(r['rollout_steps_per_s']))} env steps/s = "
            f"{ratios(ship, 'rollout_ratio_pct')} (env stepping alone: {ratios(ship, 'stepping_ratio_pct')})",
            f"≥ {AIM_ROLLOUT_PCT:g}%" + ("" if roll_ok else " (missed)"),
        ],
        [
            f"PPO training, former default ({thread8[0]['n_envs']} envs × {thread8[0]['n_steps']} on "
            f"{thread8[0]['n_threads']} threads), point / injected (same run)",
            f"{slash(thread8, lambda r: whole(r['train_steps_per_s']))} env steps/s "
            f"({ratios(thread8, 'train_ratio_pct')})",
            "",
        ],
        [
            f"PPO training, 1 core → {cores} cores, shipped config, point / injected (same run)",
            slash(zip(pinned, ship), _scaling),
            "",
        ],
    ]


@renders("hydro_run")
def hydro_run(res: Results) -> str:
    m = hydro(res)["machine"]
    return f"commit {m['commit']}, {cpu(m['cpu'])}, 1-min load average {m['load_1min']:.1f} at the start"


def per_pressure(h: dict, candidate: str, key: str) -> list[float]:
    per = h["accuracy"]["rows"][candidate]["per_pressure"]
    return [per[str(float(p))][key] for p in h["pressures_kpa"]]


def _accuracy(h: dict, candidate: str) -> str:
    acc, lim = h["accuracy"]["rows"][candidate], h["constraints"]
    omega, zeta = per_pressure(h, candidate, "omega_err_pct"), per_pressure(h, candidate, "zeta_err_pct")
    checks = [
        (f"ω {slash(omega, signed)}%", max(map(abs, omega)) <= lim["omega_err_pct"]),
        (f"ζ {slash(zeta, lambda v: signed(v, 0))}%", max(map(abs, zeta)) <= lim["zeta_err_pct"]),
        (f"ramp {acc['ramp_rmse_pct']:.2f}%", acc["ramp_rmse_pct"] <= lim["ramp_rmse_pct"]),
    ]
    met, missed = [c for c, ok in checks if ok], [c for c, ok in checks if not ok]
    if not missed:
        return "**all met**: " + ", ".join(met)
    return (", ".join(met) + " met; " if met else "") + ", ".join(missed) + " missed"


@renders("hydro_table")
def hydro_table(res: Results) -> str:
    h = hydro(res)
    lim, ps = h["constraints"], slash(h["pressures_kpa"], kpa)
    rows = []
    for cand, label in HYDRO_ROWS.items():
        s = h["speed"][cand]
        rtf_ok, env_ok = s["mean_rtf"] >= lim["rtf"], s["mean_env_steps_per_s"] >= lim["env_steps_per_s"]
        aims = {
            (True, True): "both",
            (False, False): "neither",
            (True, False): "real-time factor only",
            (False, True): "env steps/s only",
        }[(rtf_ok, env_ok)]
        rows.append(
            [
                label,
                f"{slash(s['rtf'].values(), fixed)}× ({s['mean_rtf']:.1f}×)",
                f"{slash(s['env_steps_per_s_at'].values(), whole)} ({whole(s['mean_env_steps_per_s'])}; "
                f"{whole(s['env_steps_per_s'])})",
                f"{s['speedup_twin']:.2f}× / {s['speedup_env']:.2f}×",
                _accuracy(h, cand),
                aims,
            ]
        )
    return table(
        [
            "hydroelastic setting",
            f"twin real-time factor at {ps} kPa (mean)",
            f"env steps/s at {ps} kPa (mean; pressure uniform)",
            "speed-up twin / env",
            f"accuracy (ω ≤ {lim['omega_err_pct']:g}%, ζ ≤ {lim['zeta_err_pct']:g}%, ramp ≤ {lim['ramp_rmse_pct']:g}%)",
            f"aims (≥ {lim['rtf']:g}×, ≥ {lim['env_steps_per_s']:.0f} env steps/s)",
        ],
        rows,
    )


@renders("hydro_fast_figures")
def hydro_fast_figures(res: Results) -> str:
    h = hydro(res)
    acc, fast = h["accuracy"], h["accuracy"]["rows"][HYDRO_FAST]
    ps = slash(h["pressures_kpa"], kpa)
    first = acc["ramp_against_k_d"][0]
    zeta_p0 = first["zeta"] / (1 + first["zeta_err_pct"] / 100)
    shipped = acc["rows"][HYDRO_SHIPPED]
    built_on_shipped = [r["ramp_rmse_pct"] for c, r in acc["rows"].items() if c != HYDRO_FAST]
    return "\n".join(
        [
            f"- `hydroelastic_fast` at 10 ms: k_d {slash(per_pressure(h, HYDRO_FAST, 'k_d'), lambda k: f'{k:.3f}')} at "
            f"{ps} kPa; the locked-steer decay's ζ within {fast['max_zeta_err_pct']:.2f}% of ζ(p), ω within "
            f"{fast['max_omega_err_pct']:.1f}% of a 0.02 m mesh;",
            f"- its ramp ω_d RMSE, % of peak: {fast['ramp_rmse_pct']:.2f} against its own calibration at 0.5 ms; "
            f"{fast['ramp_rmse_vs_zeta_reference_pct']:.2f} against a 0.5 ms run on the 0.05 m mesh with k_d refitted "
            f"to ζ(p₀) (mesh and step error together); {fast['ramp_rmse_vs_shipped_unrefit_pct']:.2f} against the "
            f"shipped setting at 0.5 ms with its k_d not refitted (limit {h['constraints']['ramp_rmse_pct']:g});",
            f"- the shipped k_d at 5 ms: ζ = {shipped['zeta_at_nominal']:.3f} at {acc['nominal_pressure_kpa']:g} kPa "
            f"against ζ(p₀) = {zeta_p0:.3f} ({signed(100 * (shipped['zeta_at_nominal'] / zeta_p0 - 1))}%);",
            f"- the settings built on the shipped calibration: {span(built_on_shipped, fixed2)}% of peak against that "
            f"calibration refitted at 0.5 ms (k_d {acc['refitted_reference_k_d']:.3f}, which departs "
            f"{acc['refitted_reference_ramp_rmse_vs_shipped_reference_pct']:.2f}% of peak from the unrefitted one).",
        ]
    )


@renders("hydro_uniform_mesh")
def hydro_uniform_mesh(res: Results) -> str:
    h = hydro(res)
    s = h["speed"][HYDRO_UNIFORM_COARSE]
    omega = per_pressure(h, HYDRO_UNIFORM_COARSE, "omega_err_pct")
    worst = max(range(len(omega)), key=lambda i: abs(omega[i]))
    return (
        f"runs {s['speedup_twin']:.2f}× (twin) / {s['speedup_env']:.2f}× (env) as fast but its ω is "
        f"{signed(omega[worst])}% off at {kpa(h['pressures_kpa'][worst])} kPa"
    )


@renders("injected_law_overhead")
def injected_law_overhead(res: Results) -> str:
    twin = {r["shell_model"]: r for r in res.json("benchmark.json")["twin"] if r["friction"] != "none"}
    return f"{signed(twin['injected']['overhead_pct'])}%"
