"""A curriculum over shells and pressures: training episodes go where the policy fails.

:class:`SuccessCurriculum` is an SB3 callback, named in a hyperparameter section as rl-zoo3 names
callbacks::

    callback:
      - sphere_env.training.curriculum.SuccessCurriculum:
          pressure_edges_kpa: [3.0, 5.2, 7.4, 9.6, 11.8, 14.0]
          shell_models: [injected, point]

It splits the training conditions into cells, one per shell model × pressure bin (the bins between
consecutive ``pressure_edges_kpa``), and gives every cell its own share of the training envs: each
env draws its episodes' pressure uniformly within its cell's bin and runs its cell's shell model
(``set_randomization`` with the env's own spec, every other term of the spec kept). Without
``pressure_edges_kpa`` (the default) the cells are the shell models alone and the pressure is drawn
as the env's own spec draws it (a fixed nominal pressure, for instance). After every
rollout the shares follow the training success of each cell over its last ``window_episodes``
episodes, s = (successes + 1) / (episodes + 2): a cell's weight is 1 − s, and every cell keeps at
least ``min_share`` of the envs (and at least one env), so no condition is dropped. Cells the policy
already wins get few envs, cells it fails get many. With fewer envs than cells (a short run on a
small machine) each env's cell is drawn after every rollout, distinct cells with the shares as
probabilities, from a generator seeded with the model's seed, so every cell still takes turns.

``widen_at_steps`` and ``widen_randomization`` make the curriculum staged: from the first rollout
at or after ``widen_at_steps`` environment steps, the spec every cell is built on also draws the
entries of ``widen_randomization`` (``with_entries`` of the env's spec: joint friction, the
calibration, the shell law's scales, ...), so a run first learns the task on the nominal twin and
then where the twin is unsure. A resumed run past the step starts widened. The cells and their
success counts carry over the change.

Why: under the uniform pressure draw, the better policies of the learning study won the injected
shell at 7–14 kPa in 83–100 % of their training episodes and at 3–5 kPa in 49–70 % (the
condition the grid evaluates at 3 kPa), while about a third of all episodes went to cells already
won.

A checkpoint keeps the curriculum's state (:meth:`SuccessCurriculum.state_dict`: the success
counts, the generator and each env's cell), and a resumed run continues from it: the envs start at
the cells they had, with the counts they had (:mod:`sphere_env.training.training_state`). The envs'
randomization is only changed for training: evaluation envs keep theirs.
"""

from __future__ import annotations

from collections import deque
from typing import Annotated, Any, Sequence

import numpy as np
from pydantic import AfterValidator, Field, model_validator
from stable_baselines3.common.callbacks import BaseCallback

from sphere_env.params import SHELL_MODELS
from sphere_env.schemas import Finite, Schema, allowed, count, number, validate


def _increasing(edges: list[float]) -> list[float]:
    if any(b <= a for a, b in zip(edges, edges[1:])):
        raise ValueError(f"must increase strictly, got {edges}")
    return edges


def _shell(name: str) -> str:
    if name not in SHELL_MODELS:
        raise ValueError(f"{name!r} is not a shell model")
    return name


class CurriculumArgs(Schema):
    """The keyword arguments of :class:`SuccessCurriculum`."""

    pressure_edges_kpa: (
        Annotated[
            list[Finite],
            Field(
                min_length=2,
                json_schema_extra=allowed("null (no pressure bins) or at least 2 strictly increasing pressures [kPa]"),
            ),
            AfterValidator(_increasing),
        ]
        | None
    ) = None
    shell_models: Annotated[
        list[Annotated[str, AfterValidator(_shell)]],
        Field(min_length=1, json_schema_extra=allowed(f"a non-empty list of {list(SHELL_MODELS)}")),
    ] = ["injected", "point"]
    window_episodes: count(1, 100_000) = 100
    min_share: number(ge=0.0, le=1.0) = 0.02
    widen_at_steps: number(ge=0.0, le=1e12) | None = None
    widen_randomization: dict[str, Any] | None = Field(
        default=None,
        json_schema_extra=allowed("null or a non-empty mapping parameter -> randomization entry"),
        min_length=1,
    )

    @model_validator(mode="after")
    def _both_or_neither(self) -> "CurriculumArgs":
        if (self.widen_at_steps is None) != (self.widen_randomization is None):
            raise ValueError(
                "widen_at_steps and widen_randomization: give both (a staged curriculum) or neither, "
                f"got widen_at_steps={self.widen_at_steps!r}, widen_randomization={self.widen_randomization!r}"
            )
        return self


def allocate(
    weights: Sequence[float], n_envs: int, min_share: float, rng: np.random.Generator | None = None
) -> list[int]:
    """Envs per cell: one each, the rest by ``min_share`` + (1 − cells · ``min_share``) × weight /
    Σ weights (largest remainder; ties to the earlier cell). With ``n_envs`` < cells, ``n_envs``
    distinct cells drawn by ``rng`` with those shares as probabilities get one env each."""
    w = np.asarray(weights, float)
    n = len(w)
    floor = min(min_share, 1.0 / n)
    share = floor + (1.0 - n * floor) * (w / w.sum() if w.sum() > 0 else np.full(n, 1.0 / n))
    if n_envs < n:
        if rng is None:
            raise ValueError(f"n_envs {n_envs} < {n} curriculum cells: drawing the cells needs an rng")
        chosen = rng.choice(n, size=n_envs, replace=False, p=share / share.sum())
        return [int(i in chosen) for i in range(n)]
    free = n_envs - n
    raw = share * free
    out = np.floor(raw).astype(int)
    order = sorted(range(n), key=lambda i: (-(raw[i] - out[i]), i))
    for i in order[: free - int(out.sum())]:
        out[i] += 1
    return [int(k) + 1 for k in out]


class SuccessCurriculum(BaseCallback):
    """Training envs go to the shell × pressure cells with the lowest recent training success
    (module docstring). ``pressure_edges_kpa`` [kPa] (None: cells per shell model only),
    ``shell_models``, ``window_episodes`` and ``min_share`` as :class:`CurriculumArgs`; a bad value
    is refused by name on construction."""

    def __init__(
        self,
        pressure_edges_kpa: Sequence[float] | None = None,
        shell_models: Sequence[str] = ("injected", "point"),
        window_episodes: int = 100,
        min_share: float = 0.02,
        widen_at_steps: float | None = None,
        widen_randomization: dict[str, Any] | None = None,
        verbose: int = 0,
    ):
        super().__init__(verbose)
        args = validate(
            CurriculumArgs,
            {
                "pressure_edges_kpa": None if pressure_edges_kpa is None else list(pressure_edges_kpa),
                "shell_models": list(shell_models),
                "window_episodes": window_episodes,
                "min_share": min_share,
                "widen_at_steps": widen_at_steps,
                "widen_randomization": widen_randomization,
            },
            "callback SuccessCurriculum",
        )
        self.edges = None if args.pressure_edges_kpa is None else [float(e) for e in args.pressure_edges_kpa]
        self.shell_models = list(args.shell_models)
        self.window_episodes = args.window_episodes
        self.min_share = args.min_share
        self.widen_at_steps = None if args.widen_at_steps is None else int(args.widen_at_steps)
        self.widen_randomization = args.widen_randomization
        self.widened = False
        #: the cells, (shell model, low kPa, high kPa), in a fixed order; (shell model, None, None)
        #: without pressure bins
        bins = [(None, None)] if self.edges is None else list(zip(self.edges, self.edges[1:]))
        self.cells = [(m, lo, hi) for m in self.shell_models for lo, hi in bins]
        self.outcomes = [deque(maxlen=self.window_episodes) for _ in self.cells]
        self._base: Any = None
        self._rng: np.random.Generator | None = None  # draws the cells when envs are fewer
        self._assigned: list[int] = []  # cell of each env's next episode
        self._current: list[int | None] = []  # cell of each env's running episode (None: before any)
        self._resumed = False  # state restored by load_state_dict

    def check_env(self, env: Any, n_envs: int) -> None:
        """Refuse, before training, a cell the env's randomization refuses (a pressure outside the
        calibration's range, a shell model the env cannot build); ``ValueError`` naming the field."""
        base = env.randomization
        bases = [base]
        if self.widen_randomization is not None:
            try:
                bases.append(base.with_entries(self.widen_randomization))
            except ValueError as err:
                raise ValueError(f"callback SuccessCurriculum: widen_randomization: {err}") from None
        for spec_base in bases:
            for cell in self.cells:
                try:
                    env.set_randomization(self.spec(spec_base, cell))
                except ValueError as err:
                    raise ValueError(f"callback SuccessCurriculum: cell {cell}: {err}") from None
        env.set_randomization(base)

    @staticmethod
    def spec(base: Any, cell: tuple[str, float, float]) -> Any:
        """``base`` (a randomization spec) with the shell model fixed to the cell's and the
        pressure drawn uniformly within its bin (as ``base`` draws it when the cell has no bin)."""
        model, lo, hi = cell
        if lo is None:
            return base.with_entries({"shell_model": model})
        return base.with_entries(
            {"shell_model": model, "pressure_kpa": {"distribution": "uniform", "low": lo, "high": hi}}
        )

    def success(self) -> list[float]:
        """Each cell's recent training success, (successes + 1) / (episodes + 2)."""
        return [(sum(o) + 1.0) / (len(o) + 2.0) for o in self.outcomes]

    def _widen_when_due(self) -> None:
        """From ``widen_at_steps`` on, build every cell on the widened spec (module docstring)."""
        if self.widened or self.widen_at_steps is None or self.num_timesteps < self.widen_at_steps:
            return
        self._base = self._base.with_entries(self.widen_randomization)
        self.widened = True
        self._assigned = []  # every env takes its cell's widened spec from its next episode on
        self.logger.record("curriculum/widened_at_steps", self.num_timesteps)

    def _allocate(self) -> None:
        self._widen_when_due()
        n = self.training_env.num_envs
        counts = allocate([1.0 - s for s in self.success()], n, self.min_share, self._rng)
        self._assign(self.training_env, [c for c, k in enumerate(counts) for _ in range(k)])
        self._log()

    def _assign(self, venv: Any, assigned: list[int]) -> None:
        """Give env i the cell ``assigned[i]`` from its next episode on."""
        for i, (old, new) in enumerate(zip(self._assigned or [None] * len(assigned), assigned)):
            if old != new:
                venv.env_method("set_randomization", self.spec(self._base, self.cells[new]), indices=[i])
        self._assigned = list(assigned)

    def _log(self) -> None:
        for c, (m, lo, hi) in enumerate(self.cells):
            name = f"curriculum/envs_{m}" + ("" if lo is None else f"_{lo:g}-{hi:g}_kpa")
            self.logger.record(name, self._assigned.count(c))

    def _on_training_start(self) -> None:
        if self._resumed and self._assigned:  # load_state_dict gave the envs their cells before their first episode
            self._current = list(self._assigned)
            if self.widen_at_steps is not None and not self.widened and self.num_timesteps >= self.widen_at_steps:
                self._allocate()  # resumed past the widening: the envs take the widened cells now
            self._log()
            return
        if self._resumed:  # saved before any allocation: allocate now, with the saved generator
            self._current = [None] * self.training_env.num_envs
            self._allocate()
            return
        self._base = self.training_env.get_attr("randomization", [0])[0]
        self._rng = np.random.default_rng(self.model.seed)
        self._current = [None] * self.training_env.num_envs
        self._allocate()

    def _on_step(self) -> bool:
        for i, info in enumerate(self.locals.get("infos", ())):
            if info.get("episode") is None:
                continue
            cell = self._current[i]
            if cell is not None:
                self.outcomes[cell].append(bool(info.get("is_success")))
            self._current[i] = self._assigned[i]
        return True

    def _on_rollout_end(self) -> None:
        self._allocate()

    # ---- resume ------------------------------------------------------------------------------------
    def state_dict(self) -> dict[str, Any]:
        """The curriculum's state as plain data: its cells, their recent outcomes, its generator
        and each env's cell."""
        from sphere_env.training.training_state import generator_state

        return {
            "cells": [list(c) for c in self.cells],
            "outcomes": [[bool(x) for x in o] for o in self.outcomes],
            "rng": None if self._rng is None else generator_state(self._rng),
            "assigned": list(self._assigned),
        }

    def load_state_dict(self, state: Any, venv: Any) -> None:
        """Continue from ``state`` (:meth:`state_dict`) on the training envs ``venv`` of a resumed
        run: the counts and the generator as saved, and each env at its saved cell from its next
        episode on. ``ValueError`` naming the field, before anything changes, when ``state`` is
        not this curriculum's (other cells, another number of envs)."""
        from sphere_env.training.training_state import generator_from_state

        name = "callbacks.SuccessCurriculum"
        if not isinstance(state, dict):
            raise ValueError(f"field {name!r} is a {type(state).__name__}, not a mapping")
        cells = [list(c) for c in self.cells]
        if state.get("cells") != cells:
            raise ValueError(f"field '{name}.cells': saved cells differ from the run's {cells}")
        outcomes = state.get("outcomes")
        if not (
            isinstance(outcomes, list)
            and len(outcomes) == len(cells)
            and all(isinstance(o, list) and all(isinstance(x, bool) for x in o) for o in outcomes)
        ):
            raise ValueError(f"field '{name}.outcomes': not one list of booleans per cell ({len(cells)})")
        assigned = state.get("assigned")
        n = venv.num_envs
        if not (
            isinstance(assigned, list)
            and len(assigned) in (0, n)
            and all(isinstance(c, int) and not isinstance(c, bool) and 0 <= c < len(cells) for c in assigned)
        ):
            raise ValueError(f"field '{name}.assigned': not one cell index in [0, {len(cells) - 1}] per env ({n})")
        rng = None if state.get("rng") is None else generator_from_state(state["rng"], f"{name}.rng")
        # ---- checked
        self.outcomes = [deque(o, maxlen=self.window_episodes) for o in outcomes]
        self._rng = rng
        self._base = venv.get_attr("randomization", [0])[0]
        self._assigned = []
        if assigned:
            self._assign(venv, assigned)
        self._resumed = True
