"""The conditions of an evaluation sweep: the nominal grid, and one more condition per named fault
(``--faults``, :mod:`sphere_env.evaluation.faults`) and per shipped calibration
(``--calibrations``), each run over the same shell models × friction presets × pressures × seeds.

A fault condition adds the fault's events (the env's ``randomization``) and env kwargs and runs at
the fault's own pressures where it has them (``pressure_beyond_range``), at ``fault_seeds`` where
the sweep sets them; a calibration condition builds the env with ``calibration=<name>``. Nothing
else is randomized: free randomization stays refused by the sweep. Every episode's row names its
condition (``condition``: ``nominal``, ``fault:<name>`` or ``calibration:<name>``); the
sweep's per-controller summary, plots and PME use the nominal rows, and the functions here
summarize the others: success per controller and condition (:func:`condition_rates`,
:func:`conditions_markdown`) and a graded curve per fault family (:func:`plot_fault_curves`).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np

from sphere_env.evaluation.faults import FAMILIES, GRADED_FAULTS, Fault, episode_jobs

if TYPE_CHECKING:
    from sphere_env.evaluation.evaluate import SweepSpec

NOMINAL = "nominal"
#: How a condition's name starts, per kind.
FAULT, CALIBRATION = "fault:", "calibration:"


@dataclass(frozen=True)
class Condition:
    """One condition of a sweep: its ``name`` (the rows' ``condition``), the env kwargs it sets over
    the sweep's, its events (``None``: nothing randomized), and the pressures and seeds it runs at
    instead of the grid's (``None``: the grid's)."""

    name: str
    env_kwargs: Mapping[str, Any] = field(default_factory=dict)
    randomization: Mapping[str, Any] | None = None
    pressures_kpa: tuple[float, ...] | None = None
    seeds: tuple[int, ...] | None = None

    @property
    def kind(self) -> str:
        return "fault" if self.name.startswith(FAULT) else "calibration" if self.name.startswith(CALIBRATION) else ""

    @property
    def key(self) -> str:
        """The fault's or calibration's name (``nominal`` for the nominal grid)."""
        return self.name.partition(":")[2] or self.name


def fault_condition(fault: Fault, seeds: Sequence[int] | None = None) -> Condition:
    return Condition(
        FAULT + fault.name,
        dict(fault.env_kwargs),
        dict(fault.randomization),
        fault.pressures_kpa,
        None if seeds is None else tuple(seeds),
    )


def sweep_conditions(spec: SweepSpec) -> list[Condition]:
    """The nominal grid, then one condition per fault and per calibration of ``spec``."""
    return [
        Condition(NOMINAL),
        *(fault_condition(GRADED_FAULTS[f], spec.fault_seeds) for f in spec.faults),
        *(Condition(CALIBRATION + c, {"calibration": c}) for c in spec.calibrations),
    ]


def condition_jobs(spec: SweepSpec, base_kwargs: Mapping[str, Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Every episode of ``spec`` as a :func:`sphere_env.evaluation.cells.rollout` job, per controller
    (its env kwargs ``base_kwargs[label]``), condition, shell model, friction preset, pressure and
    seed; the conditions other than the nominal grid only for ``spec.condition_controllers``."""
    jobs = []
    with_conditions = set(spec.condition_controllers or spec.labels)
    for c in spec.controllers:
        for cond in sweep_conditions(spec):
            if cond.name != NOMINAL and c.label not in with_conditions:
                continue
            kw = {**base_kwargs[c.label], **cond.env_kwargs}
            pressures = cond.pressures_kpa or spec.pressures_kpa
            seeds = cond.seeds or spec.seeds
            for model in spec.shell_models:
                for fr in spec.frictions:
                    episodes = [(model, p, s) for p in pressures for s in seeds]
                    for job in episode_jobs(c.label, c.spec, spec.env_id, kw, episodes, cond.randomization, fr):
                        job["condition"] = cond.name
                        jobs.append(job)
    return jobs


def check_condition_envs(jobs: Sequence[Mapping[str, Any]]) -> None:
    """Build the env of every distinct (env kwargs, events) of the non-nominal jobs once (point
    shell) and reset it at each of their pressures, so that a condition the env refuses stops the
    sweep before any worker starts (ValueError naming the condition)."""
    import gymnasium as gym

    envs: dict[str, tuple[Mapping[str, Any], set[float]]] = {}
    for job in jobs:
        if job["condition"] == NOMINAL:
            continue
        key = json.dumps(
            [job["env_id"], job["condition"], job["env_kwargs"], job.get("randomization")], sort_keys=True, default=str
        )
        envs.setdefault(key, (job, set()))[1].add(job["pressure_kpa"])
    for job, pressures in envs.values():
        try:
            env = gym.make(
                job["env_id"],
                shell_model="point",
                randomization=job.get("randomization", "off"),
                **job["env_kwargs"],
            )
        except (TypeError, ValueError) as err:
            raise ValueError(f"condition {job['condition']!r}: the env refuses it: {err}") from None
        try:
            for p in sorted(pressures):
                env.reset(seed=int(job["seed"]), options={"pressure_kpa": p})
        except ValueError as err:
            raise ValueError(f"condition {job['condition']!r}: the env refuses it: {err}") from None
        finally:
            env.close()


def _rate(rows: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    return {
        "success_rate": float(np.mean([bool(r["is_success"]) for r in rows])),
        "episodes": len(rows),
    }


def condition_rates(rows: Sequence[Mapping[str, Any]]) -> dict[str, dict[str, dict[str, dict[str, Any]]]]:
    """``{controller: {"faults": {fault: {success_rate, episodes}}, "calibrations": {...}}}`` over
    the rows of every condition other than the nominal grid (a controller without any: empty
    mappings)."""
    out: dict[str, dict[str, dict[str, dict[str, Any]]]] = {}
    groups: dict[tuple[str, str], list[Mapping[str, Any]]] = {}
    for r in rows:
        out.setdefault(r["controller"], {"faults": {}, "calibrations": {}})
        if r["condition"] != NOMINAL:
            groups.setdefault((r["controller"], r["condition"]), []).append(r)
    for (ctrl, cond), rs in groups.items():
        kind, _, name = cond.partition(":")
        out[ctrl]["faults" if kind + ":" == FAULT else "calibrations"][name] = _rate(rs)
    return out


def _what(cond: Condition) -> str:
    if cond.kind == "fault":
        return GRADED_FAULTS[cond.key].title
    if cond.kind == "calibration":
        return f"the env built with assets/calibration/{cond.key}.yaml"
    return "the grid as given"


def conditions_markdown(rows: Sequence[Mapping[str, Any]], spec: SweepSpec) -> str:
    """The report's section on the conditions: success per controller under each (the nominal grid
    first), with each fault's title; empty when the sweep has no condition but the nominal one."""
    from sphere_env.reporting import markdown_table

    conds = sweep_conditions(spec)
    if len(conds) == 1:
        return ""
    labels = [lab for lab in spec.labels if any(r["controller"] == lab and r["condition"] != NOMINAL for r in rows)]
    groups = [(cond.name, _what(cond), [r for r in rows if r["condition"] == cond.name]) for cond in conds]
    if spec.faults and spec.fault_seeds and set(spec.fault_seeds) != set(spec.seeds):
        at = [r for r in groups[0][2] if r["seed"] in spec.fault_seeds]  # the faults' baseline: same commands
        name = f"{NOMINAL}, seeds {', '.join(map(str, spec.fault_seeds))}"
        groups.insert(1, (name, "the grid at the faults' seeds: their baseline", at))
    table = []
    for name, what, mine in groups:
        line: dict[str, Any] = {
            "condition": name,
            "what": what,
            "episodes": len([r for r in mine if r["controller"] == labels[0]]),
        }
        for lab in labels:
            line[lab] = _rate([r for r in mine if r["controller"] == lab])["success_rate"]
        table.append(line)
    seeds = f"seeds {', '.join(map(str, spec.fault_seeds))}" if spec.fault_seeds else "the grid's seeds"
    cols = [("condition", "condition", ""), ("what", "what", ""), ("episodes", "episodes per controller", "{:d}")]
    cols += [(lab, lab, "{:.0%}") for lab in labels]
    return "\n".join(
        [
            "## Success per condition",
            "",
            f"Each condition is the grid above under one fault or calibration ({spec.env_id}); faults run at "
            f"{seeds} and at their own pressures where they set them. What each fault is, and why its range: "
            "`sphere_env.evaluation.faults` (`GRADED_FAULTS`).",
            "",
            markdown_table(table, cols),
            "",
        ]
    )


def fault_curves(rows: Sequence[Mapping[str, Any]]) -> dict[str, dict[str, list[tuple[float, float, int]]]]:
    """Per fault family and controller, ``(level, success rate, episodes)`` sorted by level: each
    fault of the family in the rows, and the nominal grid's episodes at the seeds those faults ran
    at (so that every point of a curve has the same commands) at the family's nominal level; the
    pressure family per pressure. Families without a fault in the rows are left out."""
    by_family: dict[str, dict[str, dict[float, list[bool]]]] = {}
    seeds: dict[tuple[str, str], set[int]] = {}
    for r in rows:
        if not r["condition"].startswith(FAULT):
            continue
        fault = GRADED_FAULTS[r["condition"][len(FAULT) :]]
        level = r["pressure_kpa"] if fault.level is None else fault.level
        by_family.setdefault(fault.family, {}).setdefault(r["controller"], {}).setdefault(level, []).append(
            bool(r["is_success"])
        )
        seeds.setdefault((fault.family, r["controller"]), set()).add(r["seed"])
    for family, per_ctrl in by_family.items():
        for ctrl, levels in per_ctrl.items():
            for r in rows:
                if r["condition"] == NOMINAL and r["controller"] == ctrl and r["seed"] in seeds[family, ctrl]:
                    level = r["pressure_kpa"] if FAMILIES[family].nominal is None else FAMILIES[family].nominal
                    levels.setdefault(level, []).append(bool(r["is_success"]))
    return {
        fam: {
            ctrl: [(lev, float(np.mean(v)), len(v)) for lev, v in sorted(levels.items())]
            for ctrl, levels in by_family[fam].items()
        }
        for fam in FAMILIES
        if fam in by_family
    }


def plot_fault_curves(
    rows: Sequence[Mapping[str, Any]], labels: Sequence[str], path: Path, calibrated_kpa: tuple[float, float]
) -> Path | None:
    """One panel per fault family: success rate against the fault's level, one line per controller
    (colours as the sweep's other plots), the nominal level marked (the pressure family: the
    ``calibrated_kpa`` range shaded); None without fault rows."""
    curves = fault_curves(rows)
    if not curves:
        return None
    from sphere_env.plotting import pyplot, save_figure

    plt = pyplot()
    n = len(curves)
    ncol = min(3, n)
    nrow = -(-n // ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(3.6 * ncol, 2.8 * nrow), squeeze=False, sharey=True)
    for ax, (family, per_ctrl) in zip(axes.flat, curves.items()):
        for ctrl, pts in per_ctrl.items():
            k = list(labels).index(ctrl) if ctrl in labels else len(labels)
            ax.plot([p[0] for p in pts], [p[1] for p in pts], marker="o", ms=4, color=f"C{k}", label=ctrl)
        nominal = FAMILIES[family].nominal
        if nominal is not None:
            ax.axvline(nominal, color="k", lw=0.6, ls=":")
        else:
            ax.axvspan(*calibrated_kpa, color="k", alpha=0.06, lw=0)
        ax.set_xlabel(FAMILIES[family].axis, fontsize=8)
        ax.set_title(family, fontsize=9)
        ax.set_ylim(-0.05, 1.05)
        ax.grid(alpha=0.3)
    for ax in axes.flat[n:]:
        ax.set_visible(False)
    for row in axes:
        row[0].set_ylabel("success rate")
    h, lab = axes[0][0].get_legend_handles_labels()
    fig.legend(h, lab, loc="upper center", ncol=len(lab), fontsize=8, bbox_to_anchor=(0.5, 1.0))
    fig.suptitle(
        "Success against the fault's level (dotted: nominal; shaded: calibrated pressures)", y=1.03, fontsize=9
    )
    fig.tight_layout()
    return save_figure(fig, path, bbox_inches="tight")
