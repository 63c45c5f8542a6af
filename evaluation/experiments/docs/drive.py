"""Blocks of ``docs/calibration.md`` on the drive direction: ``validation/drive_fit.json`` (``calibrate drive-fit``)."""

from __future__ import annotations

from sphere_env.evaluation.experiments.docs.base import Results, renders, slash, table

#: α tracked this closely [rad] counts as followed: no tracking lag.
TRACKED_RAD = 0.02
SHORT = {"drive_forward": "forward", "drive_backward": "backward", "drive_all": "whole"}
#: Parameter names as the page writes them.
PARAM_TEXT = {
    "drive_friction_scale": "drive friction ×",
    "injected_rolling_damping_factor": "C_drive / C_inject",
    "dissipation_s_per_m": "dissipation [s/m]",
    "spin_damping_nms_per_rad": "C_spin [N m s/rad]",
}


def _drive(res: Results) -> dict:
    return res.json("validation/drive_fit.json")


def _three(x: float) -> str:
    return f"{x:.3f}"


@renders("drive_runtime")
def drive_runtime(res: Results) -> str:
    return f"about {_drive(res)['runtime_s'] / 60:.0f} min"


@renders("drive_windows")
def drive_windows(res: Results) -> str:
    """The driven windows of the free-robot log the drive fit replayed [s from its first sample]."""
    w = _drive(res)["windows"]

    def s(name: str) -> str:
        return f"{w[name][0]:g}–{w[name][1]:g} s"

    return f"{s('drive_all')} from its first sample: forward {s('drive_forward')}, backward {s('drive_backward')}"


@renders("drive_replay_table")
def drive_replay_table(res: Results) -> str:
    """Every calibration and model on the forward / backward parts before any drive fit, with the torques."""
    d = _drive(res)
    rows = []
    for r_f in (r for r in d["replay"] if r["window"] == "drive_forward"):
        r_b = next(
            r
            for r in d["replay"]
            if r["window"] == "drive_backward" and r["model"] == r_f["model"] and r["calibration"] == r_f["calibration"]
        )
        both = (r_f, r_b)
        rows.append(
            [
                f"`{r_f['calibration']}`",
                r_f["model"],
                slash((r["rmse"]["omega_d"] for r in both), _three),
                slash((r["rmse"]["heading_rate"] for r in both), _three),
                slash((r["rmse"]["phi"] for r in both), _three),
                slash((r["rmse"]["pendulum_pitch"] for r in both), _three),
                slash(
                    (
                        max(r["torques"]["steer"]["peak_requested_nm"] for r in both),
                        r_f["torques"]["steer"]["limit_nm"],
                    ),
                    lambda x: f"{x:.0f}",
                ),
                slash(
                    (
                        max(r["torques"]["drive"]["peak_requested_nm"] for r in both),
                        r_f["torques"]["drive"]["limit_nm"],
                    ),
                    lambda x: f"{x:.0f}",
                ),
                f"{100 * max(r['torques']['steer']['saturated_fraction'] for r in both):.0f} %",
            ]
        )
    return table(
        [
            "calibration",
            "model",
            "ω_d RMSE fwd / bwd [rad/s]",
            "ψ̇ RMSE fwd / bwd [rad/s]",
            "φ RMSE fwd / bwd [rad]",
            "α tracking RMSE [rad]",
            "steer torque asked / limit [N m]",
            "drive torque asked / limit [N m]",
            "steer at its limit",
        ],
        rows,
        ["left", "left", "right", "right", "right", "right", "right", "right", "right"],
    )


def _param(fit: dict, name: str) -> str:
    lo, hi = fit["ci95"][name]
    mark = " (unidentified)" if name in fit["unidentified"] else ""
    return f"{PARAM_TEXT[name]} {fit['params'][name]:.3g} [{lo:.2g}, {hi:.2g}]{mark}"


@renders("drive_fit_table")
def drive_fit_table(res: Results) -> str:
    """Each model fitted on one part and tested on the other: parameters, held-out RMSE, ratios, aims."""
    rows = []
    for r in _drive(res)["fits"]:
        h = r["held_out_rmse"]
        soft = r["model"] != "point"
        rows.append(
            [
                f"`{r['base_calibration']}`",
                r["model"],
                f"{SHORT[r['fit_on']]} → **{SHORT[r['test']]}**",
                "; ".join(_param(r["fit"], k) for k in r["fit"]["params"]),
                f"{h['omega_d']:.3f} / {h['heading_rate']:.3f}",
                slash((r["ratio_to_point"][k] for k in ("omega_d", "heading_rate")), lambda x: f"{x:.2f}")
                if soft
                else "—",
                slash((r["ratio_to_before_fit"][k] for k in ("omega_d", "heading_rate")), lambda x: f"{x:.2f}")
                if soft
                else "—",
                slash(("yes" if r["aims_met"][k] else "**no**" for k in ("omega_d", "heading_rate"))) if soft else "—",
            ]
        )
    return table(
        [
            "from",
            "model",
            "fit on → **held out**",
            "fitted, 95 % interval",
            "held-out ω_d / ψ̇ RMSE [rad/s]",
            "÷ point (ω_d / ψ̇)",
            "÷ before the fit",
            "aims ω_d ≤ 0.15 / ψ̇ ≤ 0.10",
        ],
        rows,
        ["left", "left", "left", "left", "right", "right", "right", "left"],
    )


@renders("drive_fit_diagnosis")
def drive_fit_diagnosis(res: Results) -> str:
    """What the held-out replays miss, measured (``drive_fit.diagnose``)."""
    rows = []
    for r in _drive(res)["fits"]:
        g = r["diagnosis"]
        rows.append(
            [
                f"`{r['base_calibration']}`",
                r["model"],
                SHORT[r["test"]],
                f"{g['rmse_tracking_theta_rad']:.3f} / {g['rmse_tracking_pendulum_pitch_rad']:.3f}",
                f"{g['omega_d_lag_s']:+.2f} s → {g['omega_d_rmse_after_lag']:.3f}",
                f"{g['heading_rate_lag_s']:+.2f} s → {g['heading_rate_rmse_after_lag']:.3f}",
                f"{g['omega_d_gain']:.2f}",
                f"{g['turning_ratio_log']:.2f} / {g['turning_ratio_twin']:.2f}",
                f"{g['phi_mean_error_rolling_rad']:+.3f}",
                f"{g['heading_rate_rmse_at_log_lean']:.3f}",
                f"{r['torques']['steer']['peak_requested_nm']:.0f} / {r['torques']['drive']['peak_requested_nm']:.0f}",
            ]
        )
    return table(
        [
            "from",
            "model",
            "held out",
            "tracking θ / α RMSE [rad]",
            "ω_d: best shift → RMSE",
            "ψ̇: best shift → RMSE",
            "ω_d gain log / twin",
            "turning ratio log / twin",
            "twin's φ − log's while rolling [rad]",
            "ψ̇ RMSE at the log's lean [rad/s]",
            "peak torque asked, steer / drive [N m]",
        ],
        rows,
        ["left", "left", "left", "right", "right", "right", "right", "right", "right", "right", "right"],
    )


def _tracking(r: dict) -> str:
    """Whether the pendulum followed the log in the held-out replay (tracking lag), measured."""
    alpha = r["diagnosis"]["rmse_tracking_pendulum_pitch_rad"]
    if alpha <= TRACKED_RAD:
        return f"The pendulum is tracked within {alpha:.3f} rad in α (no tracking lag)"
    drive = r["torques"]["drive"]
    return (
        f"The pendulum is not tracked: α misses by {alpha:.3f} rad, the drive motor at its {drive['limit_nm']:.0f} "
        f"N m limit {100 * drive['saturated_fraction']:.0f} % of the time (the fitted resistance asks more torque "
        "than the motor has)"
    )


def _miss_reason(r: dict, ch: str) -> str:
    """Why a held-out signal misses its aim, from the measured diagnosis (no guess): what tracking, a
    time shift, a gain and the turning kinematics each account for."""
    g = r["diagnosis"]
    lag, after = g[f"{ch}_lag_s"], g[f"{ch}_rmse_after_lag"]
    parts = []
    parts.append(
        f"the best match moves the twin {abs(lag):.2f} s {'later' if lag < 0 else 'earlier'} (it "
        f"{'leads' if lag < 0 else 'trails'} the log) and leaves {after:.3f} rad/s"
    )
    if ch == "omega_d":
        parts.append(f"the log's ω_d is {g['omega_d_gain']:.2f} × the twin's (least squares)")
    else:
        parts.append(
            f"the twin leans {g['phi_mean_error_rolling_rad']:+.3f} rad off the log while rolling, and turned at the "
            f"log's lean its ψ̇ RMSE would be {g['heading_rate_rmse_at_log_lean']:.3f} rad/s; per unit of −ω_d sin φ "
            f"the log turns {g['turning_ratio_log']:.2f} and the twin {g['turning_ratio_twin']:.2f} (1 = rolling "
            "without spin about the ground normal)"
        )
    return "; ".join(parts)


@renders("drive_fit_summary")
def drive_fit_summary(res: Results) -> str:
    """Per soft model and held-out part: the aims met or missed, and for a miss what the diagnosis measured."""
    lines = []
    names = {"omega_d": "ω_d", "heading_rate": "ψ̇"}
    for r in _drive(res)["fits"]:
        if r["model"] == "point":
            continue
        h, aims = r["held_out_rmse"], _drive(res)["aims_rad_s"]
        verdicts = [
            f"{names[ch]} {h[ch]:.3f} rad/s ({'meets' if r['aims_met'][ch] else '**misses**'} ≤ {aims[ch]:g})"
            for ch in aims
        ]
        line = (
            f"- {r['model']} from `{r['base_calibration']}`, fitted on the {SHORT[r['fit_on']]} part, held out "
            f"{SHORT[r['test']]}: " + ", ".join(verdicts)
        )
        misses = [ch for ch in aims if not r["aims_met"][ch]]
        if misses:
            line += ". " + _tracking(r) + ". " + " ".join(f"{names[ch]}: {_miss_reason(r, ch)}." for ch in misses)
        lines.append(line)
    return "\n".join(lines)


@renders("drive_fit_steer_windows")
def drive_fit_steer_windows(res: Results) -> str:
    """What each soft fit does to the free robot's rocking windows (φ / θ RMSE before → after, worst window)."""
    rows = []
    for r in _drive(res)["fits"]:
        w = r.get("steer_windows_rmse")
        if not w:
            continue
        cells = [
            f"{max(v[when][ch] for v in w.values()):.3f}" for when in ("before", "after") for ch in ("phi", "theta")
        ]
        rows.append(
            [
                f"`{r['base_calibration']}`",
                r["model"],
                SHORT[r["fit_on"]],
                f"{cells[0]} / {cells[1]} → {cells[2]} / {cells[3]}",
            ]
        )
    return table(
        ["from", "model", "fit on", "worst φ / θ RMSE over the rocking windows, before → after [rad]"],
        rows,
        ["left", "left", "left", "right"],
    )
