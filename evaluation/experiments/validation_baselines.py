"""The PD on the validation grid: the development grid's shells and pressures at evaluation seeds
100-102 (:data:`~sphere_env.evaluation.experiments.learning.VALIDATION_SEEDS`), deterministic,
randomization off. Its success less 3 points is the PD level that a run's validation figures are
held against, so that reaching PD level is judged on validation episodes alone: the development
grid's figures are for reporting. Writes ``evaluation/results/learning/baselines_validation.json``.

    python -m evaluation.experiments.validation_baselines
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Sequence

from sphere_env.evaluation.faults import PRESSURES_KPA, SHELLS, grid_jobs
from sphere_env.files import write_text_atomic

FILE = "baselines_validation.json"


def validation_baselines(results: Path | None = None) -> Path:
    """The PD on the validation grid: ``<results>/baselines_validation.json``."""
    from sphere_env.evaluation.cells import rollout
    from sphere_env.evaluation.experiments.learning import ENV_ID, RESULTS, VALIDATION_SEEDS, _commit, grid_figures

    results = RESULTS if results is None else results
    rows = [rollout(job)[0] for job in grid_jobs("pd", "pd", ENV_ID, {}, seeds=VALIDATION_SEEDS)]
    out = {
        "pd": grid_figures(rows),
        "grid": {
            "shells": list(SHELLS),
            "pressures_kpa": list(PRESSURES_KPA),
            "seeds": list(VALIDATION_SEEDS),
            "episodes": len(rows),
        },
        "commit": _commit(),
    }
    path = results / FILE
    write_text_atomic(path, json.dumps(out, indent=1) + "\n")
    return path


def main(argv: Sequence[str] | None = None) -> None:
    if argv:
        raise SystemExit(f"validation_baselines: takes no arguments, got {list(argv)}")
    print(validation_baselines())


if __name__ == "__main__":
    main(sys.argv[1:])
