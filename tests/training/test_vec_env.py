"""BatchedSubprocVecEnv (blocks of envs: the calling process's and the workers') and ThreadedVecEnv
(several envs stepped by threads) behave exactly like DummyVecEnv."""

from __future__ import annotations

import multiprocessing as mp
import subprocess
import sys
from functools import partial

import numpy as np
import pytest
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.vec_env import DummyVecEnv

from sphere_env.training.env_factory import make_env
from sphere_env.training.vec_env import BatchedSubprocVecEnv, ThreadedVecEnv, _Pickler
from tests.conftest import TINY_PPO


def assert_same_rollout(a, b, steps: int, check_reset_infos: bool = False) -> int:
    """Step ``a`` and ``b`` in lockstep from one seed with the same random actions; observations,
    rewards, dones and infos (terminal observations and episode returns included) must be
    identical. Returns the number of episodes that ended."""
    a.seed(3)
    b.seed(3)
    np.testing.assert_array_equal(a.reset(), b.reset())
    rng = np.random.default_rng(0)
    dones = 0
    for _ in range(steps):
        act = rng.uniform(-1, 1, (a.num_envs, 2)).astype(np.float32)
        oa, ra, da, ia = a.step(act)
        ob, rb, db, ib = b.step(act)
        np.testing.assert_array_equal(oa, ob)
        np.testing.assert_array_equal(ra, rb)
        np.testing.assert_array_equal(da, db)
        for x, y in zip(ia, ib):
            assert x.keys() == y.keys()
            assert x["pressure_kpa"] == y["pressure_kpa"]
            if "terminal_observation" in x:
                np.testing.assert_array_equal(x["terminal_observation"], y["terminal_observation"])
                assert x["episode"]["r"] == y["episode"]["r"]
        if check_reset_infos:
            assert [r.get("pressure_kpa") for r in a.reset_infos] == [r.get("pressure_kpa") for r in b.reset_infos]
        dones += int(da.sum())
    return dones


def test_worker_messages_carry_arrays_bit_for_bit():
    """The pipes' pickler sends numeric arrays as bytes: every dtype, shape and bit comes back, in a
    writable array, and what it does not cover (non-contiguous, object arrays) goes numpy's way."""
    import io
    import pickle

    arrays = [
        np.array([0.1, -0.0, np.nan, np.inf], dtype=np.float64),
        np.arange(6, dtype=np.float32).reshape(2, 3),
        np.array(3.5),
        np.zeros((0, 2), dtype=np.float32),
        np.array([True, False]),
        np.arange(4, dtype=">i4"),
        np.arange(10.0)[::3],  # not contiguous
        np.array([None, "x"], dtype=object),
    ]
    message = {"obs": arrays, "same": arrays[0], "again": arrays[0]}
    buf = io.BytesIO()
    _Pickler(buf, pickle.HIGHEST_PROTOCOL).dump(message)
    back = pickle.loads(buf.getvalue())
    for a, b in zip(arrays, back["obs"]):
        assert type(b) is np.ndarray and b.dtype == a.dtype and b.shape == a.shape
        assert a.dtype == object and list(a) == list(b) or a.tobytes() == b.tobytes()
        assert b.flags.writeable
    assert back["same"] is back["again"] is back["obs"][0]  # one array, sent once


@pytest.mark.slow
def test_batched_equals_dummy_over_episodes_with_resets():
    kw = {"shell_model": "point", "randomization": "default", "ramp_length_m": 1.0}
    fns = [partial(make_env, "sphere_env/RampDescent-v0", kw, seed) for seed in range(5)]
    a, b = DummyVecEnv(fns), BatchedSubprocVecEnv(fns, n_workers=3)
    try:
        # blocks of 2, 2, 1: the first stepped by this process, the others by one worker each
        assert [len(x) for x in b.blocks] == [2, 2, 1] and len(b.processes) == 2 and b.num_envs == 5
        # 1 m ramps: several episodes end and auto-reset (a worker sends a reset info once, when it
        # changes; the vector env keeps it until that env's next reset, as DummyVecEnv does)
        dones = assert_same_rollout(a, b, 120, check_reset_infos=True)
        assert dones >= 5
        assert b.get_attr("shell_model") == ["point"] * 5
        assert b.get_attr("spec", indices=[4])[0].id == "sphere_env/RampDescent-v0"
        assert b.env_is_wrapped(Monitor) == [True] * 5
    finally:
        a.close()
        b.close()


#: Run as a script in a fresh interpreter, whose fork server is not yet started: builds the vector
#: env named by argv[1] with two workers, then prints whether a probe forked by the fork server
#: ignores SIGINT at its first instruction.
_PROBE = """
import multiprocessing as mp
import signal
import sys
from functools import partial

from sphere_env.training.env_factory import make_env
from sphere_env.training.vec_env import BatchedSubprocVecEnv, SafeSubprocVecEnv


def disposition(queue):
    queue.put(signal.getsignal(signal.SIGINT) == signal.SIG_IGN)


if __name__ == "__main__":
    fns = [partial(make_env, "sphere_env/RampDescent-v0", {"shell_model": "point"}, s) for s in range(2)]
    vec = BatchedSubprocVecEnv(fns, n_workers=2) if sys.argv[1] == "batched" else SafeSubprocVecEnv(fns)
    try:
        ctx = mp.get_context("forkserver")
        queue = ctx.Queue()
        probe = ctx.Process(target=disposition, args=(queue,))
        probe.start()
        print(queue.get(timeout=60))
        probe.join(timeout=60)
    finally:
        vec.close()
"""


@pytest.mark.skipif("forkserver" not in mp.get_all_start_methods(), reason="no forkserver start method here")
@pytest.mark.parametrize("vec_env", ["batched", "one_process_per_env"])
def test_workers_are_forked_ignoring_ctrl_c_before_their_own_code_runs(vec_env, tmp_path):
    """The fork server that starts either vector env's workers hands out processes that ignore
    SIGINT from the fork on, so a Ctrl-C during a worker's seconds of unpickling (imports of torch,
    SB3 and Drake) never raises in it: a probe forked by that server ignores SIGINT at its first
    instruction. Each vector env starts the server in a fresh interpreter, so neither finds it
    started by the other."""
    script = tmp_path / "probe.py"
    script.write_text(_PROBE)
    done = subprocess.run(
        [sys.executable, str(script), vec_env], capture_output=True, text=True, timeout=300, check=False
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split()[-1] == "True"


def test_threaded_equals_dummy_over_episodes_with_resets():
    """4 envs on 3 threads (uneven blocks), 1 m ramps so episodes end and auto-reset: observations,
    rewards, dones, infos and reset infos identical to DummyVecEnv, step by step."""
    kw = {"shell_model": "point", "randomization": "default", "ramp_length_m": 1.0}
    fns = [partial(make_env, "sphere_env/RampDescent-v0", kw, seed) for seed in range(4)]
    a, b = DummyVecEnv(fns), ThreadedVecEnv(fns, n_threads=3)
    try:
        assert b.num_envs == 4 and [len(x) for x in b.blocks] == [2, 1, 1]
        a.seed(3)
        b.seed(3)
        a.reset(), b.reset()
        assert [r["pressure_kpa"] for r in a.reset_infos] == [r["pressure_kpa"] for r in b.reset_infos]
        dones = assert_same_rollout(a, b, 100, check_reset_infos=True)
        assert dones >= 4
        assert b.get_attr("shell_model") == ["point"] * 4
        assert b.env_is_wrapped(Monitor) == [True] * 4
    finally:
        a.close()
        b.close()


def test_threaded_n_threads_checked():
    fns = [partial(make_env, "sphere_env/RampDescent-v0", {"shell_model": "point"}, 0)]
    with pytest.raises(ValueError, match=r"^n_threads = 2: .*; allowed: an integer within \[1, 1\]$"):
        ThreadedVecEnv(fns, n_threads=2)
    with pytest.raises(ValueError, match=r"^n_workers = 0: .*; allowed: an integer within \[1, 1\]$"):
        BatchedSubprocVecEnv(fns, n_workers=0)


@pytest.mark.slow
def test_layouts_train_the_same_network():
    """The trainer's layouts (blocks in this process and a worker, 2 threads, 1 thread) step the same
    rollouts, so a short PPO run with VecNormalize trains bit-identical networks. (SB3's
    SubprocVecEnv hands VecNormalize float64 rewards, so its networks differ in the last bits.)"""
    import torch

    from sphere_env.training.config import algo_class, resolve_config
    from sphere_env.training.env_factory import make_vec_env, wrap_normalize
    from sphere_env.training.session import unchecked_distributions

    tiny = {**TINY_PPO, "n_envs": 3}
    params = {}
    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # as the trainer sets it (--torch-threads)
    for name, layout in {
        "blocks": {"n_workers": 2},
        "threads": {"n_threads": 2},
        "one thread": {"n_threads": 1},
    }.items():
        cfg = resolve_config(
            "sphere_env/RampDescent-v2",
            "ppo",
            overrides={**tiny, **layout},
            env_kwargs={"shell_model": "point"},
            seed=5,
            build_env=False,
        )
        venv = wrap_normalize(cfg, make_vec_env(cfg, None))
        try:
            model = algo_class("ppo")(cfg.policy, venv, seed=5, device="cpu", **cfg.algo_kwargs())
            with unchecked_distributions():
                model.learn(total_timesteps=2 * 3 * 64)
            params[name] = torch.nn.utils.parameters_to_vector(model.policy.parameters()).detach()
        finally:
            venv.close()
    torch.set_num_threads(threads)
    assert torch.equal(params["blocks"], params["threads"])
    assert torch.equal(params["blocks"], params["one thread"])
