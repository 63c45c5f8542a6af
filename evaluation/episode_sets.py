"""The three disjoint episode sets of the learning figures: development, validation and test.

``episode_sets.yml`` beside this module fixes them (why each exists is said there). An episode is a
shell model, a pressure [kPa] and the seed its reset takes (the command profile and everything the
env draws); every shell model runs at every pressure of a set. A set gives its seeds either as a
list shared by every (shell, pressure) cell (``seeds``) or as ``seeds_per_cell`` new seeds per
cell counted from ``first_seed``, so that no two episodes of the set share a seed. Loading checks
that no seed is in two sets and that every evaluation seed lies above the training envs'
(``training.max_env_seed``).
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import Annotated, NamedTuple

from pydantic import Field, model_validator

from sphere_env import safe_yaml
from sphere_env.params import SHELL_MODELS
from sphere_env.schemas import Schema, validate

EPISODE_SETS = Path(__file__).resolve().parent / "episode_sets.yml"
SET_NAMES = ("development", "validation", "test")


class Episode(NamedTuple):
    """One episode: unpacks as ``(shell model, pressure [kPa], seed)``, the form evaluation jobs take."""

    shell_model: str
    pressure_kpa: float
    seed: int

    @property
    def distinct_key(self) -> tuple:
        """What tells episodes apart: point contact ignores the pressure."""
        return (
            (self.shell_model, self.seed)
            if self.shell_model == "point"
            else (self.shell_model, self.pressure_kpa, self.seed)
        )


class SetFields(Schema):
    pressures_kpa: list[Annotated[float, Field(gt=0.0, le=20.0)]] = Field(min_length=1)
    seeds: list[Annotated[int, Field(ge=0)]] | None = None
    first_seed: Annotated[int, Field(ge=0)] | None = None
    seeds_per_cell: Annotated[int, Field(ge=1, le=100)] | None = None

    @model_validator(mode="after")
    def _one_seed_form(self):
        if (self.seeds is None) == (self.first_seed is None or self.seeds_per_cell is None):
            raise ValueError("give either seeds, or first_seed with seeds_per_cell")
        return self


class TrainingFields(Schema):
    max_env_seed: Annotated[int, Field(ge=0)]


class EpisodeSetsFile(Schema):
    training: TrainingFields
    sets: dict[str, SetFields]

    @model_validator(mode="after")
    def _disjoint(self):
        if sorted(self.sets) != sorted(SET_NAMES):
            raise ValueError(f"sets: {sorted(self.sets)}; allowed: exactly {list(SET_NAMES)}")
        owner: dict[int, str] = {}
        for name in SET_NAMES:
            for ep in _episodes(self.sets[name]):
                if ep.seed <= self.training.max_env_seed and name != "development":
                    raise ValueError(
                        f"sets.{name}: seed {ep.seed} is a training env seed; allowed: > training.max_env_seed "
                        f"= {self.training.max_env_seed}"
                    )
                if owner.setdefault(ep.seed, name) != name:
                    raise ValueError(
                        f"sets.{name}: seed {ep.seed} is also in sets.{owner[ep.seed]}; the sets are disjoint"
                    )
        return self


def _episodes(s: SetFields) -> tuple[Episode, ...]:
    cells = [(m, p) for m in SHELL_MODELS for p in s.pressures_kpa]
    if s.seeds is not None:
        return tuple(Episode(m, p, k) for m, p in cells for k in s.seeds)
    n = s.seeds_per_cell
    return tuple(Episode(m, p, s.first_seed + i * n + k) for i, (m, p) in enumerate(cells) for k in range(n))


@lru_cache(maxsize=4)
def load(path: Path = EPISODE_SETS) -> EpisodeSetsFile:
    """The episode sets file, validated (``ValueError`` naming the file and the field)."""
    return validate(EpisodeSetsFile, safe_yaml.load_file(path), str(path))


def episodes(name: str, path: Path = EPISODE_SETS) -> tuple[Episode, ...]:
    """The episodes of set ``name`` (``development``, ``validation`` or ``test``), shells outermost."""
    if name not in SET_NAMES:
        raise ValueError(f"episode set {name!r}; allowed: {list(SET_NAMES)}")
    return _episodes(load(path).sets[name])


def check_training_seed(seed: int, n_envs: int, path: Path = EPISODE_SETS) -> None:
    """Refuse a training run seed whose env seeds (``seed`` … ``seed + n_envs − 1``) would reach an
    evaluation set's seeds."""
    top = load(path).training.max_env_seed
    if seed < 0 or seed + n_envs - 1 > top:
        raise ValueError(
            f"seed = {seed}: its {n_envs} training envs take seeds {seed}-{seed + n_envs - 1}; allowed: seeds whose "
            f"envs stay within 0-{top}, below every evaluation episode's seed (evaluation/episode_sets.yml)"
        )
