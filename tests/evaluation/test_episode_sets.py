"""The three episode sets of the learning figures: disjoint, fixed in one file, refused when not."""

from __future__ import annotations

import pytest
import yaml

from sphere_env.evaluation.episode_sets import EPISODE_SETS, SET_NAMES, check_training_seed, episodes, load
from sphere_env.params import SHELL_MODELS


def test_the_committed_sets_are_disjoint_and_above_the_training_seeds():
    top = load().training.max_env_seed
    seeds = {name: {e.seed for e in episodes(name)} for name in SET_NAMES}
    assert not seeds["development"] & seeds["validation"]
    assert not seeds["development"] & seeds["test"]
    assert not seeds["validation"] & seeds["test"]
    assert min(seeds["validation"] | seeds["test"]) > top


def test_the_test_set_holds_27_distinct_episodes_at_new_pressures_on_every_shell():
    test, dev = episodes("test"), episodes("development")
    assert len(test) == 27 and len({e.distinct_key for e in test}) == 27
    assert {e.shell_model for e in test} == set(SHELL_MODELS)
    assert not {e.pressure_kpa for e in test} & {e.pressure_kpa for e in dev}
    # the development grid: point contact ignores the pressure, so 27 episodes are 21 distinct ones
    assert len(dev) == 27 and len({e.distinct_key for e in dev}) == 21


def _write(tmp_path, data):
    path = tmp_path / "sets.yml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_a_seed_in_two_sets_is_refused_naming_the_set(tmp_path):
    data = yaml.safe_load(EPISODE_SETS.read_text())
    data["sets"]["test"] = {"pressures_kpa": [4.5], "seeds": [101]}
    with pytest.raises(ValueError, match=r"sets\.test: seed 101 is also in sets\.validation"):
        load(_write(tmp_path, data))


def test_an_evaluation_seed_among_the_training_seeds_is_refused(tmp_path):
    data = yaml.safe_load(EPISODE_SETS.read_text())
    data["sets"]["validation"]["seeds"] = [50, 51, 52]
    with pytest.raises(ValueError, match=r"sets\.validation: seed 50 is a training env seed"):
        load(_write(tmp_path, data))


def test_a_run_seed_whose_envs_reach_the_evaluation_seeds_is_refused():
    top = load().training.max_env_seed
    check_training_seed(top - 31, 32)
    with pytest.raises(ValueError, match=r"seed = 69: its 32 training envs take seeds 69-100"):
        check_training_seed(top - 30, 32)
