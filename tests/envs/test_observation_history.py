"""``observation_history_steps``: the observation carries the last k observations and actions."""

import gymnasium as gym
import numpy as np
import pytest

import sphere_env  # noqa: F401

ENV_ID = "sphere_env/RampDescent-v3"
KW = dict(
    shell_model="point",
    observe_tracking_state=True,
    observe_pressure=True,
    observe_shell_model=True,
    randomization="off",
)


def test_history_holds_the_earlier_observations_and_actions_most_recent_first():
    k = 3
    env = gym.make(ENV_ID, observation_history_steps=k, **KW)
    layout = env.unwrapped.observation_layout
    n_own = layout.own.stop
    obs, _ = env.reset(seed=0)
    seen, sent = [obs[layout.own].copy()] * k, [np.zeros(2, np.float32)] * k  # at reset: the start, no action
    rng = np.random.default_rng(1)
    for _ in range(6):
        hist = obs[layout.history]
        assert np.array_equal(hist[: n_own * k].reshape(k, n_own), np.array(seen[-k:][::-1]))
        assert np.array_equal(hist[n_own * k :].reshape(k, 2), np.array(sent[-k:][::-1]))
        action = rng.uniform(-0.5, 0.5, 2).astype(np.float32)
        seen.append(obs[layout.own].copy())
        sent.append(action)
        obs, *_ = env.step(action)
    assert obs[layout["action_drive@-1"]] == sent[-1][1]
    assert obs[layout["omega_d@-2"]] == seen[-2][layout["omega_d"]]


def test_history_keeps_the_privileged_components_last_and_the_own_ones_unchanged():
    plain = gym.make(ENV_ID, **KW)
    hist = gym.make(ENV_ID, observation_history_steps=4, **KW)
    lp, lh = plain.unwrapped.observation_layout, hist.unwrapped.observation_layout
    assert len(lh) == len(lp) + 4 * (lp.own.stop + 2)
    assert lh.privileged.stop - lh.privileged.start == 4 and lh.privileged.stop == len(lh)
    o_plain, _ = plain.reset(seed=3)
    o_hist, _ = hist.reset(seed=3)
    for _ in range(5):  # the same episode: history only appends
        assert np.array_equal(o_hist[lh.own], o_plain[lp.own])
        assert np.array_equal(o_hist[lh.privileged], o_plain[lp.privileged])
        a = np.array([0.1, -0.3], np.float32)
        o_plain, *_ = plain.step(a)
        o_hist, *_ = hist.step(a)


@pytest.mark.parametrize("value", [21, -1, 2.5, "4", True])
def test_bad_history_lengths_are_refused_by_name(value):
    with pytest.raises(ValueError, match="observation_history_steps"):
        gym.make(ENV_ID, observation_history_steps=value, **KW)
