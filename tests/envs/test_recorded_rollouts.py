"""Recorded rollouts: an env id's behaviour does not change while its version does not.

For every registered id (:data:`sphere_env.ENV_IDS`) with the point and the injected shell, plus a
short hydroelastic episode (20 steps), one with every randomized parameter, sensing and
actuation fault, the observation history and the privileged observations, and one with every
parameter of the env's action and observation stages in each mode, :data:`CASES` holds a
seeded episode prefix: ``gym.make(id, **kwargs)``, ``reset(seed=SEED)``, then up to ``steps`` actions drawn
uniformly in [-1, 1] from ``np.random.default_rng(ACTION_SEED)`` (the prefix stops early if the
episode ends). ``tests/data/recorded_rollouts/<case>.npz`` holds what that episode returned, as
float64 (exact for the env's float32 observations): the actions, observations, rewards,
terminated/truncated, every numeric ``info`` entry (``params`` flattened as ``params/<name>``,
vectors as ``name[i]``) and the other entries (shell model, fired events, ...) as JSON text, step
0 being the reset. The test
re-runs each case and requires every value to be bit-identical (``np.array_equal``, NaN equal to
NaN); a failure names the case, the step and the first component that differs. A parameter added
to the registry after a recording shows in ``info["params"]`` but not in the recording: its entry
is left out of the comparison when it holds the parameter's nominal value at every step (a new
parameter left at its nominal value must not change what an existing id returns, which the other
entries then check); at any other value it fails as a differing entry.

**Re-recording.** A change that alters what an existing id returns is a new env version: register
the new id in :data:`sphere_env.ENV_IDS` (for example ``sphere_env/RampDescent-v4``) with the new
behaviour and leave the old ids as they were, so their recordings keep passing untouched. Record
the new id's cases (the cases are generated from ``ENV_IDS``; ``test_every_registered_id_is_recorded``
fails until they exist) from the repository root with::

    .venv/bin/python -m tests.envs.test_recorded_rollouts sphere_env/RampDescent-v4

(arguments: env ids or case names; none = every case). Re-record an existing id only when its
behaviour changed for a reason that is not a change of the env (a new Drake or NumPy release
changing the floating-point results): then re-record every case and say why in the commit message.
"""

from __future__ import annotations

import json
import sys
import warnings
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import sphere_env
from sphere_env.params import PARAMETERS

DATA = Path(__file__).resolve().parents[1] / "data" / "recorded_rollouts"
SEED = 7
ACTION_SEED = 11
STEPS = 60
#: Every randomized parameter (the ``full`` preset) and every sensing and actuation fault at once; the
#: motor torque scale is drawn again every 0.3 s (interval events).
FAULTS = {
    "base": "full",
    "observation_noise_scale": 1.0,
    "action_latency_steps": 1,
    "motor_torque_scale": {"distribution": "uniform", "low": 0.8, "high": 1.0, "mode": "interval", "interval_s": 0.3},
}
#: Every parameter of the env's action and observation stages, in every mode: the noise drawn again
#: every 0.1 s, two steps of latency, a saturation that tightens at 0.5 /s from the limit, and a steer
#: torque bias drawn at reset and again every 0.14 s.
STAGES = {
    "observation_noise_scale": {"low": 0.5, "high": 3.0, "mode": "interval", "interval_s": 0.1},
    "action_latency_steps": 2,
    "motor_torque_scale": {"value": 1.0, "mode": "schedule", "rate_per_s": -0.5},
    "steer_torque_offset_nm": {"low": -5.0, "high": 5.0, "mode": "interval", "interval_s": 0.14},
}


def _cases() -> dict[str, dict[str, Any]]:
    cases = {}
    for env_id in sphere_env.ENV_IDS:
        for shell in ("point", "injected"):
            cases[f"{env_id.split('/')[-1]}_{shell}"] = {
                "env_id": env_id,
                "kwargs": {"shell_model": shell},
                "steps": STEPS,
            }
    cases["RampDescent-v3_injected_faults"] = {
        "env_id": "sphere_env/RampDescent-v3",
        "steps": STEPS,
        "kwargs": {
            "shell_model": "injected",
            "randomization": FAULTS,
            "observation_history_steps": 2,
            "observe_pressure": True,
            "observe_shell_model": True,
        },
    }
    cases["RampDescent-v3_point_stages"] = {
        "env_id": "sphere_env/RampDescent-v3",
        "steps": STEPS,
        "kwargs": {"shell_model": "point", "randomization": STAGES, "observation_history_steps": 1},
    }
    cases["Roll-v1_hydroelastic"] = {
        "env_id": "sphere_env/Roll-v1",
        "kwargs": {"shell_model": "hydroelastic"},
        "steps": 20,
    }
    return cases


#: case name -> {"env_id", "kwargs", "steps"}
CASES = _cases()


def _flatten(info: dict[str, Any]) -> tuple[dict[str, float], dict[str, Any]]:
    """(numeric entries, one per component: ``name`` or ``name[i]``; the other entries) of a
    step's ``info``."""
    numeric: dict[str, float] = {}
    other: dict[str, Any] = {}
    items = [(k, v) for k, v in info.items() if k != "params"]
    items += [(f"params/{k}", v) for k, v in info.get("params", {}).items()]
    for key, value in items:
        arr = np.asarray(value)
        if arr.dtype.kind not in "biuf":
            other[key] = value
        elif arr.ndim == 0:
            numeric[key] = float(arr)
        else:
            numeric.update({f"{key}[{i}]": float(x) for i, x in enumerate(arr.ravel())})
    return numeric, other


def run_case(case: dict[str, Any]) -> dict[str, np.ndarray]:
    """The arrays of one case's episode prefix (the layout of the recorded files)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # gymnasium flags the superseded versions as out of date
        env = gym.make(case["env_id"], **case["kwargs"])
    try:
        nominal = env.unwrapped.nominal_params
        rng = np.random.default_rng(ACTION_SEED)
        obs, info = env.reset(seed=SEED)
        steps = [(np.full(2, np.nan), obs, np.nan, False, False, info)]
        for _ in range(case["steps"]):
            action = rng.uniform(-1, 1, 2).astype(np.float32)
            obs, reward, terminated, truncated, info = env.step(action)
            steps.append((action, obs, reward, terminated, truncated, info))
            if terminated or truncated:
                break
    finally:
        env.close()
    infos = [_flatten(s[5]) for s in steps]
    names = sorted(set().union(*(numeric for numeric, _ in infos)))
    return {
        "action": np.array([s[0] for s in steps], dtype=np.float64),
        "observation": np.array([s[1] for s in steps], dtype=np.float64),
        "reward": np.array([s[2] for s in steps], dtype=np.float64),
        "terminated": np.array([s[3] for s in steps]),
        "truncated": np.array([s[4] for s in steps]),
        # an entry absent from a step's info is NaN there; which are present is in info_present
        "info_names": np.array(names),
        "info": np.array([[numeric.get(k, np.nan) for k in names] for numeric, _ in infos], dtype=np.float64),
        "info_present": np.array([[k in numeric for k in names] for numeric, _ in infos]),
        "info_other": np.array([json.dumps(other, sort_keys=True, default=str) for _, other in infos]),
        "nominal": np.array(json.dumps(nominal, sort_keys=True, default=str)),
    }


def record(names: list[str]) -> None:
    """Write the recordings of the named cases (or of every case of these env ids)."""
    DATA.mkdir(parents=True, exist_ok=True)
    for name, case in CASES.items():
        if names and name not in names and case["env_id"] not in names:
            continue
        path = DATA / f"{name}.npz"
        np.savez_compressed(path, **run_case(case))
        print(
            f"{path.relative_to(Path.cwd()) if path.is_relative_to(Path.cwd()) else path}: "
            f"{path.stat().st_size / 1e3:.1f} kB"
        )


def _added_at_nominal(now: dict[str, np.ndarray], recorded: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """``now`` without the ``params/<name>`` entries the recording lacks whose ``<name>`` is a
    registry parameter holding its nominal value at every step (a parameter added since the
    recording, left at its nominal value: the env's own, ``now["nominal"]``, where it has one,
    such as a calibration kwarg, else the registry's)."""
    env_nominal = json.loads(str(now["nominal"])) if "nominal" in now else {}

    def nominal(key: str, values) -> bool:
        name = key.removeprefix("params/").split("[")[0]
        if not key.startswith("params/") or name not in PARAMETERS:
            return False
        nom = env_nominal.get(name, PARAMETERS[name].nominal)
        nom = tuple(nom) if isinstance(nom, list) else nom
        nom = nom[int(key.split("[")[1].rstrip("]"))] if "[" in key and isinstance(nom, tuple) else nom
        return all(v == nom for v in values)

    names, old = list(now["info_names"]), set(recorded["info_names"])
    keep = [i for i, k in enumerate(names) if k in old or not nominal(k, now["info"][:, i])]
    old_other = set().union(*(json.loads(str(text)) for text in recorded["info_other"]))
    other = []
    for text in now["info_other"]:
        entries = json.loads(str(text))
        for key in [k for k in entries if k not in old_other and nominal(k, [entries[k]])]:
            del entries[key]
        other.append(json.dumps(entries, sort_keys=True))
    return {
        **now,
        "info_names": now["info_names"][keep],
        "info": now["info"][:, keep],
        "info_present": now["info_present"][:, keep],
        "info_other": np.array(other),
    }


#: What each step is compared on, in this order.
COMPONENTS = ("action", "observation", "reward", "terminated", "truncated", "info_present", "info", "info_other")


def test_every_registered_id_is_recorded():
    missing = [name for name in CASES if not (DATA / f"{name}.npz").is_file()]
    assert not missing, f"no recording of {missing}: record them (module docstring)"


def test_an_entry_the_recording_lacks_is_left_out_only_at_its_parameters_nominal_value():
    recorded = {"info_names": np.array(["params/pressure_kpa"]), "info_other": np.array(["{}"])}

    def now(offset: float) -> dict[str, np.ndarray]:
        return {
            "info_names": np.array(["params/pressure_kpa", "params/steer_friction_scale", "theta"]),
            "info": np.array([[8.0, 1.0, 0.1], [8.0, offset, 0.2]]),
            "info_present": np.ones((2, 3), bool),
            "info_other": np.array(["{}", "{}"]),
        }

    assert list(_added_at_nominal(now(1.0), recorded)["info_names"]) == ["params/pressure_kpa", "theta"]
    assert list(_added_at_nominal(now(1.5), recorded)["info_names"]) == list(now(1.5)["info_names"])


@pytest.mark.parametrize("name", list(CASES))
def test_rollout_is_bit_identical_to_the_recording(name):
    case = CASES[name]
    path = DATA / f"{name}.npz"
    if not path.is_file():
        pytest.fail(f"{case['env_id']} ({name}): no recording at {path} (module docstring)")
    with np.load(path) as f:
        recorded = dict(f)
    now = _added_at_nominal(run_case(case), recorded)
    where = f"{case['env_id']} with {case['kwargs']} (case {name})"
    assert len(now["reward"]) == len(recorded["reward"]), (
        f"{where}: the episode prefix has {len(now['reward']) - 1} steps, recorded {len(recorded['reward']) - 1}"
    )
    names = list(recorded["info_names"])
    assert list(now["info_names"]) == names, (
        f"{where}: numeric info entries differ: {sorted(set(now['info_names']) ^ set(names))}"
    )
    for t in range(len(recorded["reward"])):
        for comp in COMPONENTS:
            a, b = recorded[comp][t], now[comp][t]
            if np.array_equal(a, b, equal_nan=a.dtype.kind == "f"):
                continue
            if np.ndim(a) == 0:
                pytest.fail(f"{where}: step {t} (0 = reset) differs first in {comp!r}: recorded {a!r}, now {b!r}")
            i = next(i for i, (x, y) in enumerate(zip(a, b)) if not (x == y or (x != x and y != y)))
            part = f"info {names[i]!r}" if comp.startswith("info") else f"{comp}[{i}]"
            pytest.fail(f"{where}: step {t} (0 = reset) differs first in {part}: recorded {a[i]!r}, now {b[i]!r}")


if __name__ == "__main__":
    record(sys.argv[1:])
