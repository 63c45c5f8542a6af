"""A resumed training run continues its random streams: the envs draw the episodes the run would
have drawn next (not its first ones again), the curriculum keeps its counts, generator and
allocation, and a checkpoint written before the random state was saved still resumes, saying that
the streams restart."""

from __future__ import annotations

import json
import shutil
from types import SimpleNamespace

import numpy as np
import pytest

from sphere_env.training.curriculum import SuccessCurriculum
from sphere_env.training.run_folder import latest_checkpoint
from sphere_env.training.train import main
from sphere_env.training.trainer import train
from sphere_env.training.training_state import read, state_path
from tests.conftest import TINY_PPO

RAMP = "sphere_env/RampDescent-v0"
# Two envs, short episodes (so each env plays several after the resume), pressures randomized.
TINY_RUN = {
    **TINY_PPO,
    "n_envs": 2,
    "env_kwargs": {"shell_model": "point", "randomization": {"pressure_kpa": [3.0, 14.0]}},
    "env_wrapper": [{"gymnasium.wrappers.TimeLimit": {"max_episode_steps": 10}}],
}


def _episodes_after(run, steps: int) -> dict[int, list[dict]]:
    """Each env's training episodes logged after ``steps``: their drawn parameters, in order."""
    import csv

    out: dict[int, list[dict]] = {}
    with open(run / "learning_curve_train.csv", newline="") as f:
        for row in csv.DictReader(f):
            if int(row["timesteps"]) > steps:
                out.setdefault(int(row["env"]), []).append(json.loads(row["params"]))
    return out


def _copy_at(run, dst, steps: int):
    """A copy of ``run`` cut back to its checkpoint at ``steps`` (as if it had stopped there)."""
    shutil.copytree(run, dst)
    for p in (dst / "checkpoints").iterdir():
        if f"_{steps}_steps" not in p.name:
            p.unlink()
    return dst


@pytest.mark.slow
def test_a_resumed_run_draws_the_episodes_an_uninterrupted_run_draws_next(tmp_path, capsys):
    from sphere_env.training.config import resolve_config

    cfg = resolve_config(RAMP, "ppo", overrides={**TINY_RUN, "n_timesteps": 256}, seed=5, checkpoint_freq=128)
    whole = train(cfg, tmp_path / "whole", progress_bar=False)
    assert read(state_path(whole, 128))["num_timesteps"] == 128

    resumed = _copy_at(whole, tmp_path / "resumed", 128)
    main(["--resume", str(resumed), "--no-progress"])
    assert latest_checkpoint(resumed)[0] == 256
    want, got = _episodes_after(whole, 128), _episodes_after(resumed, 128)
    assert sorted(got) == [0, 1]
    for env, episodes in got.items():
        assert len(episodes) >= 3
        # the episode running at the checkpoint is dropped; the next ones are the uninterrupted run's
        assert episodes[:-1] == want[env][1 : len(episodes)], env

    # A checkpoint without the saved state (an older run folder) resumes, with the streams restarted.
    old = _copy_at(whole, tmp_path / "old", 128)
    state_path(old, 128).unlink()
    capsys.readouterr()
    main(["--resume", str(old), "--n-timesteps", "192", "--no-progress"])
    warning = [line for line in capsys.readouterr().err.splitlines() if "random streams restart" in line]
    assert len(warning) == 1
    first = {env: eps[0]["pressure_kpa"] for env, eps in _episodes_after(whole, 0).items()}
    again = {env: eps[0]["pressure_kpa"] for env, eps in _episodes_after(old, 128).items()}
    assert again == first  # what the warning says: the run's first episodes are drawn again


@pytest.mark.slow
def test_a_corrupt_random_state_skips_its_checkpoint_by_name(tmp_path, capsys):
    from sphere_env.training.config import resolve_config

    cfg = resolve_config(RAMP, "ppo", overrides={**TINY_RUN, "n_timesteps": 128}, seed=1, checkpoint_freq=64)
    run = train(cfg, tmp_path / "run", progress_bar=False)
    state = json.loads(state_path(run, 128).read_text())
    state["envs"][1]["bit_generator"] = "os.system"
    state_path(run, 128).write_text(json.dumps(state))
    capsys.readouterr()
    main(["--resume", str(run), "--n-timesteps", "192", "--no-progress"])
    err = capsys.readouterr().err
    assert "rl_model_training_state_128_steps.json" in err
    assert "field 'envs[1].bit_generator' = 'os.system': not a numpy bit generator" in err
    assert "falling back to the checkpoint at 64 steps" in err


class _Envs:
    """The training envs a curriculum sees: their count, base randomization and set_randomization."""

    def __init__(self, n: int):
        self.num_envs = n
        self.specs: list = [None] * n

    def get_attr(self, name, indices=None):
        return [SimpleNamespace(with_entries=lambda entries: dict(entries))]

    def env_method(self, name, spec, indices):
        self.specs[indices[0]] = spec


def _started(cb: SuccessCurriculum, envs: _Envs, seed: int = 3) -> SuccessCurriculum:
    from stable_baselines3.common.logger import Logger

    cb.model = SimpleNamespace(logger=Logger(None, []), seed=seed, get_env=lambda: envs)
    cb.locals = {}
    cb._on_training_start()
    return cb


def _rounds(cb: SuccessCurriculum, outcomes) -> list[list[int]]:
    """Feed each round's episode outcomes (one per env), end the rollout; the allocations."""
    out = []
    for won in outcomes:
        cb.locals = {"infos": [{"episode": {}, "is_success": w} for w in won]}
        cb._on_step()
        cb._on_rollout_end()
        out.append(list(cb._assigned))
    return out


def test_the_curriculum_continues_from_its_saved_state():
    kw = {"shell_models": ["injected", "point", "hydroelastic"], "window_episodes": 5}
    rng = np.random.default_rng(0)
    before, after = rng.random((6, 2)) < 0.5, rng.random((8, 2)) < 0.5
    original = _started(SuccessCurriculum(**kw), _Envs(2))
    _rounds(original, before)
    saved = json.loads(json.dumps(original.state_dict()))  # what a checkpoint keeps, as JSON

    envs = _Envs(2)
    restored = SuccessCurriculum(**kw)
    restored.load_state_dict(saved, envs)
    assert [s["shell_model"] for s in envs.specs] == [original.cells[c][0] for c in original._assigned]
    _started(restored, envs)
    assert restored.success() == original.success()
    continued = _rounds(original, after)
    assert _rounds(restored, after) == continued
    # a fresh curriculum (counts and generator restarted) allocates otherwise
    assert _rounds(_started(SuccessCurriculum(**kw), _Envs(2)), after) != continued


@pytest.mark.parametrize(
    "change, field",
    [
        ({"cells": [["point", None, None]]}, "cells"),
        ({"outcomes": [[1], [], []]}, "outcomes"),
        ({"assigned": [0, 7]}, "assigned"),
        ({"rng": {"bit_generator": "os.system"}}, "bit_generator"),
    ],
)
def test_a_curriculum_state_that_does_not_fit_is_refused_by_name(change, field):
    kw = {"shell_models": ["injected", "point", "hydroelastic"]}
    state = {**_started(SuccessCurriculum(**kw), _Envs(2)).state_dict(), **change}
    cb = SuccessCurriculum(**kw)
    with pytest.raises(ValueError, match=field):
        cb.load_state_dict(state, _Envs(2))
    assert cb._assigned == [] and not cb._resumed


@pytest.mark.parametrize("layout", ["batched", "subproc"])
def test_a_step_left_unanswered_does_not_answer_the_next_command(layout):
    """A step interrupted between sending and receiving (Ctrl-C) leaves replies in the workers'
    pipes; the checkpoint's request for the envs' generators must get generators, not those replies."""
    from functools import partial

    import gymnasium as gym

    from sphere_env.training.vec_env import BatchedSubprocVecEnv, SafeSubprocVecEnv

    fns = [partial(gym.make, "Pendulum-v1")] * 3
    venv = BatchedSubprocVecEnv(fns, n_workers=3) if layout == "batched" else SafeSubprocVecEnv(fns)
    try:
        venv.seed(0)
        venv.reset()
        venv.step_async(np.zeros((3, 1), np.float32))  # ... and the interrupt comes before step_wait
        gens = venv.get_attr("np_random")
        assert [type(g) for g in gens] == [np.random.Generator] * 3
        venv.set_attr("np_random", np.random.default_rng(7), indices=[1])
        assert venv.get_attr("np_random", [1])[0].bit_generator.state == np.random.default_rng(7).bit_generator.state
        obs, *_ = venv.step(np.zeros((3, 1), np.float32))  # the envs step on, in step
        assert obs.shape == (3, 3)
    finally:
        venv.close()
