"""Blocks on the drive fit in the shipped calibrations and the envs that use it: the calibration
files' ``drive_fit`` records, and ``drive_fit_envs.json`` (``python -m evaluation.experiments.drive_fit_envs``:
the PD and the shipped policy on RampDescent-v3 and -v4)."""

from __future__ import annotations

from sphere_env.evaluation.experiments.docs.base import Results, percent, renders, slash, table
from sphere_env.evaluation.experiments.docs.drive import PARAM_TEXT
from sphere_env.models.calibration_schema import shipped_calibrations

V3, V4 = "sphere_env/RampDescent-v3", "sphere_env/RampDescent-v4"
SHELLS = ("point", "injected", "hydroelastic")
LABEL = {"pd": "PD", "pretrained": "shipped policy (`pretrained`, trained on v3)"}


def _envs(res: Results) -> dict:
    return res.json("drive_fit_envs.json")


def _three(x: float) -> str:
    return f"{x:.3f}"


def _two(x: float) -> str:
    return f"{x:.2f}"


@renders("drive_law_shipped")
def drive_law_shipped(res: Results) -> str:
    """Each shipped calibration's drive fit: what it was fitted on, each model's values and whether
    they are in force, or why the drive direction was not fitted."""
    rows = []
    for name in shipped_calibrations():
        rec = res.calibration(name).get("drive_fit") or {}
        if not rec.get("fitted"):
            rows.append([f"`{name}`", "not fitted", "", "", "", rec.get("reason", "no record")])
            continue
        on = f"{', '.join(rec['fit_on'])} of `{rec['log']}` (from `{rec['base_calibration']}`, {rec['commit'][:7]})"
        for model, m in rec["models"].items():
            values = "; ".join(f"{PARAM_TEXT[k]} {v:.3g}" for k, v in m["params"].items())
            poor = ", ".join(PARAM_TEXT[k] for k in m.get("unidentified") or {})
            held = m.get("held_out_rmse") or {}
            rows.append(
                [
                    f"`{name}`",
                    on if model == next(iter(rec["models"])) else "",
                    model,
                    values + (f" (unidentified: {poor})" if poor else ""),
                    slash((held.get("omega_d", float("nan")), held.get("heading_rate", float("nan"))), _three),
                    "**applied**" if m["applied"] else "not applied: " + m["not_applied_because"],
                ]
            )
    return table(
        ["calibration", "fitted on", "model", "fitted values", "held out ω_d / ψ̇ RMSE [rad/s]", "in force"], rows
    )


@renders("drive_envs_table")
def drive_envs_table(res: Results) -> str:
    """The PD and the shipped policy on the development grid, v3 against v4."""
    d = _envs(res)
    rows = []
    for ctrl in ("pd", "pretrained"):
        a, b = d["envs"][V3][ctrl], d["envs"][V4][ctrl]
        for shell in SHELLS:
            sa, sb = a["per_shell_detail"][shell], b["per_shell_detail"][shell]
            rows.append(
                [
                    LABEL[ctrl] if shell == SHELLS[0] else "",
                    shell,
                    f"{percent(sa['success_rate'])} → {percent(sb['success_rate'])}",
                    f"{_three(sa['tracking_rmse_rad_s'])} → {_three(sb['tracking_rmse_rad_s'])}",
                    f"{_two(sa['mean_omega_d_rad_s'])} → {_two(sb['mean_omega_d_rad_s'])}",
                    f"{_two(sa['time_on_ramp_s'])} → {_two(sb['time_on_ramp_s'])}",
                ]
            )
        rows.append(
            [
                "",
                "**all**",
                f"**{percent(a['success_rate'])} → {percent(b['success_rate'])}**",
                f"**{_three(a['tracking_rmse_rad_s'])} → {_three(b['tracking_rmse_rad_s'])}**",
                "",
                "",
            ]
        )
    return table(
        [
            "controller",
            "shell",
            "success v3 → v4",
            "tracking RMSE v3 → v4 [rad/s]",
            "mean ω_d on the ramp v3 → v4 [rad/s]",
            "time on the ramp v3 → v4 [s]",
        ],
        rows,
    )


@renders("drive_envs_summary")
def drive_envs_summary(res: Results) -> str:
    """One sentence: how far the ramp task's physics moved for the two controllers."""
    d = _envs(res)
    parts = []
    for ctrl in ("pd", "pretrained"):
        a, b = d["envs"][V3][ctrl], d["envs"][V4][ctrl]
        ia, ib = a["per_shell_detail"]["injected"], b["per_shell_detail"]["injected"]
        parts.append(
            f"the {LABEL[ctrl]} succeeds in {percent(b['success_rate'])} of the {b['episodes']} development "
            f"episodes on v4 against {percent(a['success_rate'])} on v3 (injected shell "
            f"{percent(ib['success_rate'])} against {percent(ia['success_rate'])}, tracking RMSE "
            f"{_three(ib['tracking_rmse_rad_s'])} against {_three(ia['tracking_rmse_rad_s'])} rad/s)"
        )
    return "; ".join(parts)
