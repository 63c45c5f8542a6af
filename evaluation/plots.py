"""The evaluation report's plots: drive velocity against time, error bars, success and tracking
error against pressure, and PME, each written to a PNG (matplotlib, headless)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np

if TYPE_CHECKING:
    from sphere_env.evaluation.evaluate import SweepSpec


def _plt():
    from sphere_env.plotting import pyplot

    return pyplot()


def plot_drive_velocity(rows, traces, spec: SweepSpec, path: Path) -> Path:
    """ω_d(t) per pressure (columns) and shell model (rows), one line per controller, first seed
    and friction preset; ω_ref dashed. As the paper's ramp experiment, with the run-out marked."""
    plt = _plt()
    nr, nc = len(spec.shell_models), len(spec.pressures_kpa)
    fig, axes = plt.subplots(nr, nc, figsize=(3.2 * nc, 2.4 * nr), sharex=True, sharey=True, squeeze=False)
    labels = spec.labels
    s0, f0 = spec.seeds[0], spec.frictions[0]
    for r, tr in zip(rows, traces):
        if r["seed"] != s0 or r["friction"] != f0:
            continue
        i, j = spec.shell_models.index(r["shell_model"]), spec.pressures_kpa.index(r["pressure_kpa"])
        ax = axes[i][j]
        k = labels.index(r["controller"])
        ax.plot(tr["t_s"], tr["omega_d"], color=f"C{k}", lw=1.2, label=r["controller"])
        if k == 0:
            ax.plot(tr["t_s"], tr["omega_ref"], "k--", lw=0.8, label="ω_ref")
        off = np.flatnonzero(tr["on_ramp"] < 0.5)
        if len(off):
            ax.axvline(tr["t_s"][off[0]], color=f"C{k}", ls=":", lw=0.8)
    for i, m in enumerate(spec.shell_models):
        axes[i][0].set_ylabel(f"{m}\nω_d [rad/s]")
    for j, p in enumerate(spec.pressures_kpa):
        axes[0][j].set_title(f"{p:g} kPa")
        axes[-1][j].set_xlabel("t [s]")
    for ax in axes.flat:
        ax.grid(alpha=0.3)
    h, lab = axes[0][0].get_legend_handles_labels()
    fig.legend(h, lab, loc="upper center", ncol=len(lab), fontsize=8, bbox_to_anchor=(0.5, 1.0))
    fig.suptitle(f"Drive velocity on the ramp (seed {s0}, friction {f0}); dotted: run-out reached", y=1.04, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path


def plot_error_bars(rows, traces, spec: SweepSpec, path: Path) -> Path:
    """Paper Figs. 13–14 style: per pressure (groups) and shell model (bars), mean on-ramp ω_d ±
    std over the on-ramp samples of all seeds (top) and tracking RMSE ± std over seeds (bottom);
    one column per controller."""
    plt = _plt()
    labels = spec.labels
    fig, axes = plt.subplots(2, len(labels), figsize=(3.6 * len(labels), 5.2), squeeze=False, sharey="row")
    w = 0.8 / len(spec.shell_models)
    x = np.arange(len(spec.pressures_kpa))
    for c, lab in enumerate(labels):
        for i, m in enumerate(spec.shell_models):
            mean, std, tm, ts = [], [], [], []
            for p in spec.pressures_kpa:
                sel = [
                    (r, tr)
                    for r, tr in zip(rows, traces)
                    if r["controller"] == lab and r["shell_model"] == m and r["pressure_kpa"] == p
                ]
                samples = np.concatenate([tr["omega_d"][tr["on_ramp"] > 0.5] for _, tr in sel]) if sel else np.array([])
                mean.append(samples.mean() if len(samples) else np.nan)
                std.append(samples.std() if len(samples) else np.nan)
                e = np.array([r["tracking_rmse_rad_s"] for r, _ in sel])
                tm.append(e.mean() if len(e) else np.nan)
                ts.append(e.std() if len(e) else np.nan)
            axes[0][c].bar(
                x + (i - (len(spec.shell_models) - 1) / 2) * w, mean, w, yerr=std, capsize=3, color=f"C{i}", label=m
            )
            axes[1][c].bar(x + (i - (len(spec.shell_models) - 1) / 2) * w, tm, w, yerr=ts, capsize=3, color=f"C{i}")
        axes[0][c].set_title(lab)
        for ax in axes[:, c]:
            ax.set_xticks(x, [f"{p:g}" for p in spec.pressures_kpa])
            ax.grid(alpha=0.3, axis="y")
        axes[1][c].set_xlabel("pressure [kPa]")
    axes[0][0].set_ylabel("on-ramp ω_d [rad/s]")
    axes[1][0].set_ylabel("tracking RMSE [rad/s]")
    axes[0][0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_success_tracking(agg_rows, spec: SweepSpec, path: Path) -> Path:
    """Success rate and tracking RMSE against pressure; colour = controller, line style = model."""
    plt = _plt()
    labels = spec.labels
    styles = ["-", "--", ":", "-."]
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    for c, lab in enumerate(labels):
        for i, m in enumerate(spec.shell_models):
            rs = sorted(
                [a for a in agg_rows if a["controller"] == lab and a["shell_model"] == m],
                key=lambda a: a["pressure_kpa"],
            )
            p = [a["pressure_kpa"] for a in rs]
            kw = dict(color=f"C{c}", ls=styles[i % 4], marker="o", ms=3, label=f"{lab} / {m}")
            axes[0].plot(p, [a["success_rate"] for a in rs], **kw)
            axes[1].errorbar(
                p,
                [a["tracking_rmse_rad_s"] for a in rs],
                yerr=[a["tracking_rmse_rad_s_std"] for a in rs],
                capsize=2,
                **kw,
            )
    axes[0].set_ylabel("success rate")
    axes[0].set_ylim(-0.05, 1.05)
    axes[1].set_ylabel("speed-tracking RMSE [rad/s]")
    for ax in axes:
        ax.set_xlabel("pressure [kPa]")
        ax.grid(alpha=0.3)
    axes[1].legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_pme(pmes: Sequence[Mapping[str, Any]], path: Path, reference: str) -> Path | None:
    """PME [%] of each model against ``reference`` vs pressure (mean ± std over seeds)."""
    sel = [r for r in pmes if r["reference"] == reference]
    if not sel:
        return None
    plt = _plt()
    fig, ax = plt.subplots(figsize=(5.5, 3.6))
    for i, sim in enumerate(sorted({r["simulation"] for r in sel})):
        ps = sorted({r["pressure_kpa"] for r in sel if r["simulation"] == sim})
        v = [[r["pme_percent"] for r in sel if r["simulation"] == sim and r["pressure_kpa"] == p] for p in ps]
        ax.errorbar(
            ps,
            [np.mean(x) for x in v],
            yerr=[np.std(x) for x in v],
            marker="o",
            capsize=3,
            color=f"C{i}",
            label=f"{sim} vs {reference}",
        )
    ax.axhline(0, color="k", lw=0.6)
    ax.set_xlabel("pressure [kPa]")
    ax.set_ylabel("PME [%] (> 0: underestimates)")
    ax.set_title("Zero-torque descent, Point Mean Error (eq. 12), on-ramp samples", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


# ---- replay --------------------------------------------------------------------------------------------
