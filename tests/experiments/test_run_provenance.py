"""How each run was made is derived from its recipe, not trusted from its result file: a
continuation is never called from scratch, resumed runs are told apart in the wall-clock table,
and the committed summary rebuilds byte for byte from the committed run files."""

from __future__ import annotations

import json
import shutil

import pytest

from sphere_env.evaluation.experiments.learning import RESULTS, load_recipes
from sphere_env.evaluation.experiments.run_provenance import (
    from_scratch,
    resumed_at,
    wall_clock_markdown,
    wall_clock_rows,
)

RECIPES = load_recipes()


def test_a_continuation_is_never_called_from_scratch():
    """Every recipe that continues another run's checkpoint (``continue_from``: curriculum_tight,
    study_faults_4m, shipped_annealed and the rest) is not from scratch for any seed; shipped's
    seed 0, which continued mix_asym_w6_steer3, is not either, while its other seeds are."""
    continuations = [name for name, r in RECIPES.items() if r.get("continue_from")]
    assert {"curriculum_tight", "study_faults_4m", "shipped_annealed"} <= set(continuations)
    for name in continuations:
        assert not any(from_scratch(RECIPES[name], seed) for seed in range(10)), name
    assert not from_scratch(RECIPES["shipped"], 0) and from_scratch(RECIPES["shipped"], 1)
    assert from_scratch(RECIPES["curriculum_scheduled"], 0)  # resumed from its own checkpoint, still from scratch


def test_the_summary_calls_no_continuation_from_scratch():
    """The committed summary derives each run's from_scratch from its recipe, whatever the result
    file recorded (runs written before the derivation all said true)."""
    summary = json.loads((RESULTS / "summary.json").read_text())
    for r in summary["runs"]:
        recipe = RECIPES.get(r["method"], {})
        if recipe.get("continue_from") or r["seed"] in (recipe.get("continued_seeds") or {}):
            assert r["from_scratch"] is False, f"{r['method']} seed {r['seed']}"
    stored = json.loads((RESULTS / "runs" / "curriculum_tight" / "seed0.json").read_text())["from_scratch"]
    derived = next(r for r in summary["runs"] if r["method"] == "curriculum_tight")["from_scratch"]
    assert derived is False and stored is True  # a stale stored field does not reach the summary


def test_a_bad_seed_field_is_refused_by_name():
    with pytest.raises(ValueError, match=r"continued_seeds: \[0\]; allowed: a mapping"):
        from_scratch({"continued_seeds": [0]}, 0)


def test_resumed_runs_and_runs_in_one_go_are_timed_apart():
    """curriculum_scheduled's seeds 0-4 were resumed from their 500 k checkpoints, seeds 5-9 ran in
    one go: two rows; a load average shows where the run recorded it, else 'not recorded'."""
    assert resumed_at(RECIPES["curriculum_scheduled"], 3) == 500_000
    assert resumed_at(RECIPES["curriculum_scheduled"], 7) is None

    def run(seed, load=None):
        return {
            "method": "curriculum_scheduled",
            "seed": seed,
            "wall_clock_s": 6000.0 + seed,
            "steps_per_s": 300.0,
            "job_wall_s": 7200.0,
            **({"load_avg_1min": load} if load else {}),
        }

    runs = [run(s) for s in range(9)] + [run(9, {"start": 2.04, "end": 3.5})]
    rows = wall_clock_rows({"curriculum_scheduled": runs}, RECIPES)
    assert [(r["seeds"], r["resumed_at_env_steps"]) for r in rows] == [
        ([5, 6, 7, 8, 9], None),
        ([0, 1, 2, 3, 4], 500_000),
    ]
    lines = wall_clock_markdown(rows).splitlines()[2:]
    cells = [[c.strip() for c in line.strip("|").split("|")] for line in lines]
    assert [c[0] for c in cells] == ["curriculum_scheduled", "curriculum_scheduled (resumed at 500 k)"]
    assert cells[0][-1] == "not recorded / not recorded / not recorded / not recorded / 2.0 → 3.5"
    assert cells[1][-1] == "not recorded"  # none of its runs recorded a load


def test_the_committed_summary_rebuilds_byte_for_byte_from_the_run_files(tmp_path):
    """summary.json and README.md of evaluation/results/learning are what the summary writes from
    the committed run files and baselines, byte for byte."""
    from sphere_env.evaluation.experiments.learning_summary import write_summary

    shutil.copytree(RESULTS / "runs", tmp_path / "runs")
    for name in ("baselines.json", "baselines_validation.json"):
        shutil.copy2(RESULTS / name, tmp_path / name)
    write_summary(tmp_path, plot=False)
    for name in ("summary.json", "README.md"):
        assert (tmp_path / name).read_bytes() == (RESULTS / name).read_bytes(), (
            f"{name} differs from its rebuild: run `python -m evaluation.experiments.learning summary`"
        )
