"""The success curriculum: it puts the training episodes in its shell × pressure cells, gives the
cells the policy fails more envs, and a set-up it cannot run is refused by name before training."""

from __future__ import annotations

import csv
import json

import gymnasium as gym
import numpy as np
import pytest
from stable_baselines3 import PPO
from stable_baselines3.common.logger import configure
from stable_baselines3.common.vec_env import DummyVecEnv

from sphere_env.training.config import resolve_config
from sphere_env.training.curriculum import SuccessCurriculum, allocate
from sphere_env.training.trainer import train
from tests.conftest import TINY_PPO

RAMP = "sphere_env/RampDescent-v0"
CURRICULUM = "sphere_env.training.curriculum.SuccessCurriculum"


def test_allocate_gives_every_cell_an_env_and_more_to_the_heavier():
    counts = allocate([0.9, 0.1, 0.5, 0.5], 16, 0.02)
    assert sum(counts) == 16 and min(counts) >= 1
    assert counts[0] > counts[2] == counts[3] > counts[1]
    assert allocate([0.0, 0.0, 0.0], 6, 0.1) == [2, 2, 2]  # no weight anywhere: even


def test_with_fewer_envs_than_cells_the_cells_are_drawn_by_weight_and_seed():
    """Two envs for four cells: two distinct cells per draw, the heavy cell drawn most often, the
    light ones still drawn (min_share), and the same draws under the same seed."""

    def draws(seed):
        rng = np.random.default_rng(seed)
        return [allocate([0.9, 0.05, 0.05, 0.0], 2, 0.05, rng) for _ in range(400)]

    got = draws(0)
    assert all(sum(c) == 2 and max(c) == 1 for c in got)
    freq = np.mean(got, axis=0)
    assert freq[0] == max(freq) > 0.8 and min(freq) > 0.05
    assert got == draws(0) and got != draws(1)
    with pytest.raises(ValueError, match="rng"):
        allocate([1.0, 1.0, 1.0], 2, 0.0)


def _episodes(tmp_path, env_kwargs, curriculum, n_timesteps=256):
    """Train two envs for ``n_timesteps`` steps with ``curriculum``; the logged training episodes."""
    over = {
        **TINY_PPO,
        "n_envs": 2,
        "n_timesteps": n_timesteps,
        "env_kwargs": {"max_episode_steps": 10, **env_kwargs},
        "callback": [{CURRICULUM: curriculum}],
    }
    cfg = resolve_config(RAMP, "ppo", overrides=over, eval_freq=0, checkpoint_freq=0)
    run = train(cfg, tmp_path / "run", progress_bar=False)
    with open(run / "learning_curve_train.csv") as f:
        return list(csv.DictReader(f))


def _later_episodes(tmp_path, env_kwargs, curriculum):
    """:func:`_episodes` after each env's first (which starts before training does)."""
    rows = _episodes(tmp_path, env_kwargs, curriculum)
    later = [r for rank in ("0", "1") for r in [r for r in rows if r["env"] == rank][1:]]
    assert len(later) >= 20
    return later


def test_the_training_episodes_run_in_the_curriculums_cells(tmp_path):
    """Two envs, cells 3-4 and 4-5 kPa on the injected shell while the env's own spec draws point
    contact over the whole range: after each env's first episode every episode is on the injected
    shell within 3-5 kPa, and both cells get episodes."""
    later = _later_episodes(
        tmp_path, {"shell_model": "point"}, {"pressure_edges_kpa": [3.0, 4.0, 5.0], "shell_models": ["injected"]}
    )
    assert all(r["shell_model"] == "injected" and 3.0 <= float(r["pressure_kpa"]) <= 5.0 for r in later)
    pressures = np.array([float(r["pressure_kpa"]) for r in later])
    assert (pressures < 4.0).any() and (pressures > 4.0).any()


def test_without_pressure_bins_the_cells_are_the_shells_and_the_pressure_stays_the_envs(tmp_path):
    """No ``pressure_edges_kpa``: one cell per shell model (the default ones, injected and point).
    The env's spec draws no pressure (the nominal one) and runs hydroelastic contact; after each
    env's first episode both envs run their cell's shell, both shells get episodes, and every
    episode keeps the env's nominal pressure."""
    later = _later_episodes(tmp_path, {"shell_model": "hydroelastic", "randomization": "off"}, {})
    assert {r["shell_model"] for r in later} == {"injected", "point"}
    nominal = gym.make(RAMP).unwrapped.parameter_space.nominal("pressure_kpa")
    assert all(float(r["pressure_kpa"]) == pytest.approx(nominal, abs=1e-3) for r in later)


def test_a_staged_curriculum_widens_the_draws_at_its_step(tmp_path):
    """Widened at 128 of 384 steps (two envs, rollouts of 2 × 32 steps, episodes of 10): the
    episodes that end by 128 steps run the nominal drive friction; those that start after the first
    rollout past 128 steps draw it over [0.5, 1.5], and the cells still fix shell and pressure."""
    rows = _episodes(
        tmp_path,
        {},
        {
            "pressure_edges_kpa": [3.0, 5.0],
            "shell_models": ["injected"],
            "widen_at_steps": 128,
            "widen_randomization": {"drive_friction_scale": [0.5, 1.5]},
        },
        n_timesteps=384,
    )
    friction = [(int(r["timesteps"]), json.loads(r["params"])["drive_friction_scale"]) for r in rows]
    assert all(f == 1.0 for t, f in friction if t <= 128)
    late = [f for t, f in friction if t > 128 + 64 + 2 * 10]  # a rollout late, each env's episode after
    assert len(late) >= 8 and all(0.5 <= f <= 1.5 for f in late) and len(set(late)) == len(late)
    assert all(r["shell_model"] == "injected" for r in rows if int(r["timesteps"]) > 128 + 64 + 20)


def test_the_cells_the_policy_fails_get_more_envs():
    envs = DummyVecEnv([lambda: gym.make(RAMP, shell_model="point", max_episode_steps=10) for _ in range(8)])
    model = PPO("MlpPolicy", envs, n_steps=16, batch_size=16, device="cpu")
    model.set_logger(configure(None, []))
    cb = SuccessCurriculum([3.0, 8.5, 14.0], shell_models=["point", "injected"], window_episodes=20)
    cb.init_callback(model)
    cb.on_training_start(locals(), globals())
    assert sorted(cb._assigned) == [0, 0, 1, 1, 2, 2, 3, 3]  # no episodes yet: even
    for c, wins in enumerate((20, 20, 20, 0)):  # the last cell (injected, 8.5-14 kPa) always failed
        cb.outcomes[c].extend([True] * wins + [False] * (20 - wins))
    cb.on_rollout_end()
    counts = [cb._assigned.count(c) for c in range(4)]
    assert counts[3] == max(counts) >= 4 and min(counts) >= 1
    for i, c in enumerate(cb._assigned):  # each env draws from its cell
        terms = {t.parameter: t.distribution for t in envs.get_attr("randomization", [i])[0].terms}
        model_name, lo, hi = cb.cells[c]
        assert terms["shell_model"].value == model_name
        assert (terms["pressure_kpa"].low, terms["pressure_kpa"].high) == (lo, hi)
    envs.close()


@pytest.mark.parametrize(
    "kwargs, n_envs, needle",
    [
        ({"pressure_edges_kpa": [1.0, 2.0]}, 4, "cell ('injected', 1.0, 2.0)"),
        ({"pressure_edges_kpa": [5.0, 3.0]}, 4, "field 'pressure_edges_kpa'"),
        ({"pressure_edges_kpa": [5.0]}, 4, "field 'pressure_edges_kpa'"),
        ({"pressure_edges_kpa": [3.0, 5.0], "shell_models": ["soft"]}, 4, "field 'shell_models[0]'"),
        ({"pressure_edges_kpa": [3.0, 5.0], "window": 10}, 4, "window"),
        ({"widen_at_steps": 100}, 4, "widen_at_steps and widen_randomization"),
        ({"widen_at_steps": 100, "widen_randomization": {"drive_friction": [0.5, 1.5]}}, 4, "widen_randomization"),
        (
            {"widen_at_steps": 100, "widen_randomization": {"drive_friction_scale": [1.5, 0.5]}},
            4,
            "widen_randomization",
        ),
    ],
)
def test_a_curriculum_it_cannot_run_is_refused_by_name_before_training(tmp_path, kwargs, n_envs, needle):
    over = {**TINY_PPO, "n_envs": n_envs, "callback": [{CURRICULUM: kwargs}]}
    with pytest.raises(ValueError, match="callback") as err:
        resolve_config(RAMP, "ppo", overrides=over, eval_freq=0)
    assert needle in str(err.value)
    assert not any(tmp_path.iterdir())


def test_a_callback_that_is_not_one_is_refused_by_name():
    over = {**TINY_PPO, "callback": "sphere_env.wrappers.PDResidualAction"}
    with pytest.raises(ValueError, match="hyperparams.callback.*not a stable_baselines3 BaseCallback"):
        resolve_config(RAMP, "ppo", overrides=over, eval_freq=0, build_env=False)
