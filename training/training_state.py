"""The random state of a training run, kept with each checkpoint so that a resume continues the
run's random streams instead of restarting them.

    checkpoints/rl_model_training_state_<steps>_steps.json

holds, as plain data (JSON: no code is run to read it):

* each training env's generator (``env.np_random``: the episodes' randomized parameters, their
  commands, sensor noise);
* the generators of the training process that stable-baselines3 draws from (torch: the policy's
  exploration; numpy's global generator: PPO's minibatches; Python's ``random``) and the model's
  action space (SAC's random actions before ``learning_starts``);
* the state of the run's callbacks that keep one (a callback with ``state_dict()`` and
  ``load_state_dict(state, venv)``, such as
  :class:`~sphere_env.training.curriculum.SuccessCurriculum`: its success counts, its generator
  and its allocation of the envs).

:func:`restore` puts them back after the model is loaded (loading reseeds every generator with the
run's seed) and before training continues: each env then starts a new episode from its restored
generator (the episode running at the checkpoint is dropped: the simulator's state is not saved).
A checkpoint written without this file (older run folders) resumes with the streams restarted from
the run's seeds, as before, and the trainer says so.
"""

from __future__ import annotations

import base64
import json
import random
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from sphere_env.files import write_text_atomic

FORMAT = 1
#: The numpy bit generators a saved state may name.
BIT_GENERATORS = ("PCG64", "PCG64DXSM", "MT19937", "Philox", "SFC64")
#: Largest training-state file read [bytes] (a run with 1000 envs writes about 0.2 MB).
MAX_BYTES = 64 * 1024 * 1024


def state_path(run_dir: Path, steps: int) -> Path:
    from sphere_env.training.run_folder import CHECKPOINT_PREFIX

    return run_dir / "checkpoints" / f"{CHECKPOINT_PREFIX}_training_state_{steps}_steps.json"


def stateful(callbacks: Sequence[Any]) -> list[Any]:
    """The callbacks that keep a state across a resume (``state_dict`` and ``load_state_dict``)."""
    return [cb for cb in callbacks if hasattr(cb, "state_dict") and hasattr(cb, "load_state_dict")]


# ---- generators as plain data ------------------------------------------------------------------------
def generator_state(gen: np.random.Generator) -> dict[str, Any]:
    """A numpy generator's bit-generator state as JSON-ready data."""
    return _plain(gen.bit_generator.state)


def generator_from_state(state: Any, name: str) -> np.random.Generator:
    """The generator whose state is ``state`` (:func:`generator_state`); ``ValueError`` naming
    ``name`` when it is none."""
    kind = state.get("bit_generator") if isinstance(state, dict) else None
    if kind not in BIT_GENERATORS:
        raise ValueError(
            f"field {name + '.bit_generator'!r} = {_short(kind)}: not a numpy bit generator; allowed: {BIT_GENERATORS}"
        )
    bit = getattr(np.random, kind)()
    try:
        bit.state = state
    except (TypeError, ValueError, KeyError, OverflowError) as err:
        raise ValueError(f"field {name!r}: not a {kind} state ({_short(err)})") from None
    return np.random.Generator(bit)


def _plain(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def _short(value: Any, limit: int = 120) -> str:
    text = repr(value) if not isinstance(value, BaseException) else str(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


# ---- save ----------------------------------------------------------------------------------------------
def collect(model: Any, callbacks: Sequence[Any]) -> dict[str, Any]:
    """The run's random state now: its envs', the process's, the action space's and the callbacks'."""
    import torch

    venv = model.get_env()
    gens = venv.get_attr("np_random")
    return {
        "format": FORMAT,
        "num_timesteps": int(model.num_timesteps),
        "envs": [generator_state(g) for g in gens],
        "torch": base64.b64encode(torch.get_rng_state().numpy().tobytes()).decode("ascii"),
        "numpy": _plain(np.random.get_state(legacy=False)),
        "python": _plain(random.getstate()),
        "action_space": generator_state(model.action_space.np_random),
        "callbacks": [{"name": type(cb).__name__, "state": cb.state_dict()} for cb in stateful(callbacks)],
    }


def save(model: Any, callbacks: Sequence[Any], run_dir: Path) -> Path:
    """Write the run's random state beside the checkpoint at the model's step count."""
    state = collect(model, callbacks)
    return write_text_atomic(state_path(run_dir, state["num_timesteps"]), json.dumps(state))


# ---- read and restore ----------------------------------------------------------------------------------
def read(path: Path) -> dict[str, Any]:
    """The training state in ``path``, every generator state in it checked (and the process's
    decoded, under ``"_process"``); ``ValueError`` naming the file and the field when it is no
    training state."""
    where = f"{str(path)!r}"
    try:
        if path.stat().st_size > MAX_BYTES:
            raise ValueError(f"{where}: larger than {MAX_BYTES} bytes; not a training state")
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, RecursionError) as err:
        raise ValueError(f"{where} cannot be read ({type(err).__name__}: {_short(err)})") from None
    if not isinstance(data, dict):
        raise ValueError(f"{where}: the input is a {type(data).__name__}, not a mapping")
    if data.get("format") != FORMAT:
        raise ValueError(f"{where}: field 'format' = {_short(data.get('format'))}; allowed: {FORMAT}")
    for key, kind in (("envs", list), ("callbacks", list), ("torch", str), ("numpy", dict), ("python", list)):
        if not isinstance(data.get(key), kind):
            raise ValueError(f"{where}: field {key!r} = {_short(data.get(key))}: not a {kind.__name__}")
    try:
        for i, env in enumerate(data["envs"]):
            generator_from_state(env, f"envs[{i}]")
        generator_from_state(data.get("action_space"), "action_space")
        data["_process"] = _process_state(data)
    except ValueError as err:
        raise ValueError(f"{where}: {err}") from None
    return data


def _process_state(data: dict[str, Any]) -> tuple[Any, Any, Any]:
    """(torch, numpy, Python) generator states of ``data``, each tried on a fresh generator."""
    import torch

    key = "torch"
    try:
        torch_state = torch.frombuffer(bytearray(base64.b64decode(data["torch"], validate=True)), dtype=torch.uint8)
        torch.Generator().set_state(torch_state)
        key = "numpy"
        np.random.RandomState().set_state(data["numpy"])
        key = "python"
        version, internal, gauss = data["python"]
        python_state = (version, tuple(internal), gauss)
        random.Random().setstate(python_state)
    except (TypeError, ValueError, KeyError, RuntimeError) as err:
        raise ValueError(f"field {key!r}: not a {key} generator state ({_short(err)})") from None
    return torch_state, data["numpy"], python_state


def restore(model: Any, state: dict[str, Any], callbacks: Sequence[Any]) -> None:
    """Put the saved random ``state`` (:func:`read`) back into a freshly loaded ``model`` (its envs
    attached) and the run's ``callbacks``, and make the next ``learn`` start a new episode in every
    env from the restored generators. ``ValueError`` naming the field, before anything changes,
    when the state does not fit the run (another number of envs, other callbacks)."""
    import torch

    venv = model.get_env()
    if len(state["envs"]) != venv.num_envs:
        raise ValueError(f"field 'envs': {len(state['envs'])} env generators saved, the run has {venv.num_envs} envs")
    saved = [c.get("name") if isinstance(c, dict) else None for c in state["callbacks"]]
    names = [type(cb).__name__ for cb in stateful(callbacks)]
    if saved != names:
        raise ValueError(f"field 'callbacks' = {_short(saved)}: the run's callbacks with a state are {names}")
    for cb, saved_cb in zip(stateful(callbacks), state["callbacks"]):
        cb.load_state_dict(saved_cb.get("state"), venv)  # checks first, then sets
    torch_state, numpy_state, python_state = state["_process"]
    torch.set_rng_state(torch_state)
    np.random.set_state(numpy_state)
    random.setstate(python_state)
    model.action_space._np_random = generator_from_state(state["action_space"], "action_space")
    for i, env_state in enumerate(state["envs"]):
        venv.set_attr("np_random", generator_from_state(env_state, f"envs[{i}]"), indices=[i])
    # Loading seeded the envs for their next reset (the run's first seeds): drop those, and have
    # learn() start every env's next episode from its restored generator.
    venv.unwrapped._reset_seeds()
    model._last_obs = None
