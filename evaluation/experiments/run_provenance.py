"""How each run of the learning study was made, derived from its recipe rather than read from its
result file: whether it trained from scratch or continued another run's checkpoint, whether it
was resumed part-way from one of its own checkpoints, and the wall-clock it took with the machine
load it ran under.

A recipe says so in ``recipes.yml``: ``continue_from`` (every seed's run continues that recipe's
run of the same seed), ``continued_seeds`` (seed -> the run and step a seed's run continued, for a
recipe whose other seeds started from scratch) and ``resumed_seeds`` (seed -> the env steps of the
checkpoint from which an interrupted run was resumed).
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

from sphere_env.reporting import markdown_table


def from_scratch(recipe: Mapping[str, Any], seed: int) -> bool:
    """Whether the run of ``recipe`` with ``seed`` trained from freshly initialized parameters: not
    a continuation of another recipe's run (``continue_from``), and not a seed that continued
    another run's checkpoint (``continued_seeds``)."""
    return not recipe.get("continue_from") and int(seed) not in _seed_keys(recipe, "continued_seeds")


def resumed_at(recipe: Mapping[str, Any], seed: int) -> int | None:
    """The env steps of the checkpoint from which the run of ``recipe`` with ``seed`` was resumed
    after an interruption (``resumed_seeds``), else None."""
    steps = _seed_keys(recipe, "resumed_seeds").get(int(seed))
    return None if steps is None else int(float(steps))


def _seed_keys(recipe: Mapping[str, Any], field: str) -> dict[int, Any]:
    got = recipe.get(field) or {}
    if not isinstance(got, Mapping):
        raise ValueError(f"{field}: {got!r}; allowed: a mapping of training seed -> value")
    return {int(k): v for k, v in got.items()}


def recipe_of(run: Mapping[str, Any], recipes: Mapping[str, Mapping[str, Any]]) -> Mapping[str, Any]:
    """A run's recipe as ``recipes.yml`` has it now (what was learned about its runs is added there
    after they ran), else as the run recorded it."""
    return recipes.get(run["method"]) or run.get("recipe") or {}


def _minutes(seconds: float | None) -> str:
    return "–" if seconds is None or seconds != seconds else f"{seconds / 60:.0f}"


def _load(load: Mapping[str, float] | None) -> str:
    return "not recorded" if not load else f"{load['start']:.1f} → {load['end']:.1f}"


def wall_clock_rows(
    runs_by_recipe: Mapping[str, Sequence[Mapping[str, Any]]], recipes: Mapping[str, Mapping[str, Any]]
) -> list[dict[str, Any]]:
    """Per recipe, and within a recipe per kind of run (trained in one go, or resumed part-way from
    a checkpoint of its own, which trains at another rate), each run's training wall-clock, its
    training rate, the wall time of its job (the training it still had to do, and the evaluation)
    and the 1-min load average at the job's start and end (None where not recorded)."""
    rows = []
    for name, runs in runs_by_recipe.items():
        kinds: dict[int | None, list[Mapping[str, Any]]] = {}
        for r in runs:
            kinds.setdefault(resumed_at(recipe_of(r, recipes), r["seed"]), []).append(r)
        for at, group in sorted(kinds.items(), key=lambda kv: -1 if kv[0] is None else kv[0]):
            rows.append(
                {
                    "recipe": name,
                    "seeds": [r["seed"] for r in group],
                    "resumed_at_env_steps": at,
                    **{k: [r.get(k) for r in group] for k in ("wall_clock_s", "steps_per_s", "job_wall_s")},
                    "load_avg_1min": [r.get("load_avg_1min") for r in group],
                }
            )
    return rows


def wall_clock_markdown(rows: Sequence[Mapping[str, Any]]) -> str:
    """:func:`wall_clock_rows` as a table, the runs of a row in seed order, separated by slashes."""

    def slash(xs) -> str:
        return " / ".join(str(x) for x in xs)

    def resumed(r: Mapping[str, Any]) -> str:
        at = r["resumed_at_env_steps"]
        return "" if at is None else f" (resumed at {at / 1e3:.0f} k)"

    return markdown_table(
        [
            [
                r["recipe"] + resumed(r),
                slash(r["seeds"]),
                slash(_minutes(x) for x in r["wall_clock_s"]),
                slash("–" if x is None else f"{x:.0f}" for x in r["steps_per_s"]),
                slash(_minutes(x) for x in r["job_wall_s"]),
                "not recorded" if not any(r["load_avg_1min"]) else slash(_load(x) for x in r["load_avg_1min"]),
            ]
            for r in rows
        ],
        [
            "recipe",
            "seeds",
            "training wall-clock, min",
            "env steps/s",
            "job wall time, min",
            "1-min load average, start → end",
        ],
    )
