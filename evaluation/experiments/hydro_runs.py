"""The runs of the hydroelastic trade-off study (:mod:`evaluation.experiments.hydro_tradeoff`): the
candidate calibrations it writes, the locked-steer free decay and the k_d refit on it, the ramp
trace, and the timed twin and env runs."""

from __future__ import annotations

import copy
import time
from pathlib import Path

import numpy as np
import yaml

from sphere_env.analysis.decay import fit_free_decay
from sphere_env.files import write_text_atomic
from sphere_env.models.shell import ShellCalibration
from sphere_env.physics import InitialState, Twin, TwinConfig

CHUNK_S = 0.02
SAMPLE_S = 0.01
RAMP = {"incline_deg": 16.0, "ramp_length_m": 4.0}
#: The opt-in pressure-dependent mesh measured here (``hydroelastic.low_pressure_mesh``).
LOW_PRESSURE_MESH = {"below_kpa": 5.0, "resolution_hint_m": 0.1}


def candidate_calibration(
    base_raw: dict, hint_m: float, low_mesh, k_d: float | None, step_s: float, path: Path
) -> Path:
    """Write the shipped calibration with its hydroelastic mesh (and k_d, fitted step) changed and no
    k_d refits at other steps."""
    raw = copy.deepcopy(base_raw)
    hyd = raw["hydroelastic"]
    hyd["resolution_hint_m"] = hint_m
    hyd.pop("low_pressure_mesh", None)
    hyd.pop("k_d_by_time_step", None)
    if low_mesh is not None:
        hyd["low_pressure_mesh"] = {"below_kpa": low_mesh[0], "resolution_hint_m": low_mesh[1]}
    if k_d is not None:
        hyd["k_d"] = float(k_d)
        hyd["fitted_time_step_s"] = float(step_s)
    ShellCalibration.from_dict(raw, source=str(path))  # validated before it is written
    return write_text_atomic(path, yaml.safe_dump(raw, sort_keys=False))


def with_low_pressure_mesh(base_raw: dict, path: Path) -> Path:
    """Write the shipped calibration as it is plus :data:`LOW_PRESSURE_MESH`."""
    raw = copy.deepcopy(base_raw)
    raw["hydroelastic"]["low_pressure_mesh"] = dict(LOW_PRESSURE_MESH)
    ShellCalibration.from_dict(raw, source=str(path))
    return write_text_atomic(path, yaml.safe_dump(raw, sort_keys=False))


def contact_polygons(twin: Twin) -> int:
    results = twin.plant.get_contact_results_output_port().Eval(twin.plant_context)
    return sum(
        results.hydroelastic_contact_info(i).contact_surface().num_faces()
        for i in range(results.num_hydroelastic_contacts())
    )


def rock(calibration: Path, pressure_kpa: float, step_s: float, k_d: float | None = None) -> dict:
    """Locked-steer free decay (the protocol k_d is matched on): ω_n, ζ and the contact polygons
    at its end. ``k_d``: use this k_d at ``step_s`` instead of the calibration's."""
    twin = Twin(
        TwinConfig(
            fixture="locked_steer",
            shell_model="hydroelastic",
            steer_friction="none",
            drive_friction="none",
            calibration=calibration,
            pressure_kpa=pressure_kpa,
            time_step_s=step_s,
        )
    )
    if k_d is not None:
        raw = copy.deepcopy(dict(twin.calibration.raw))
        raw["hydroelastic"].pop("k_d_by_time_step", None)
        raw["hydroelastic"].update(k_d=float(k_d), fitted_time_step_s=float(step_s))
        twin.set_calibration(ShellCalibration.from_dict(raw, source="<k_d trial>"))
    twin.reset(InitialState(roll=0.15))
    n = round(6.0 / SAMPLE_S)
    phi = [twin.state().phi]
    for _ in range(n):
        twin.advance(SAMPLE_S)
        phi.append(twin.state().phi)
    fit = fit_free_decay(SAMPLE_S * np.arange(n + 1), np.array(phi))
    return {"omega_n": fit.omega_n, "zeta": fit.zeta, "polygons": contact_polygons(twin)}


def refit_k_d(calibration: Path, pressure_kpa: float, step_s: float, target_zeta: float | None = None) -> float:
    """k_d at which the locked-steer decay at ``step_s`` has ``target_zeta`` (default: the ζ that the
    calibration's own k_d gives at its ``fitted_time_step_s``), both at ``pressure_kpa``."""
    from scipy.optimize import brentq

    cal = ShellCalibration.load(calibration)
    target = rock(calibration, pressure_kpa, cal.fitted_time_step_s)["zeta"] if target_zeta is None else target_zeta
    return brentq(
        lambda k: rock(calibration, pressure_kpa, step_s, k_d=k)["zeta"] - target,
        0.05 * cal.k_d,
        3.0 * cal.k_d,
        xtol=0.005 * cal.k_d,
    )


def ramp_trace(calibration: Path, step_s: float, seconds: float = 6.0) -> np.ndarray:
    twin = Twin(TwinConfig(shell_model="hydroelastic", calibration=calibration, time_step_s=step_s, **RAMP))
    twin.reset(InitialState())
    out = []
    for _ in range(round(seconds / CHUNK_S)):
        twin.advance(CHUNK_S)
        out.append(twin.state().omega_d)
    return np.array(out)


def time_twin_run(twin: Twin, pressure_kpa: float, seconds: float) -> float:
    """Wall time [s] of the benchmark's run: ``seconds`` from rest in 20 ms chunks at a pressure."""
    twin.reset(InitialState(), pressure_kpa=pressure_kpa)
    t0 = time.perf_counter()
    for _ in range(round(seconds / CHUNK_S)):
        twin.advance(CHUNK_S)
        twin.state()
    return time.perf_counter() - t0


def time_env(env, rng: np.random.Generator, seconds: float, pressure_kpa: float | None = None) -> tuple[int, float]:
    """(env steps, wall s) of random-action stepping for about ``seconds`` from a fresh episode;
    resets not timed. ``pressure_kpa`` fixes the pressure of every episode (``None``: the env's
    randomization draws it)."""
    options = None if pressure_kpa is None else {"pressure_kpa": pressure_kpa}
    env.reset(options=options)
    n, wall = 0, 0.0
    while wall < seconds:
        actions = rng.uniform(-1.0, 1.0, size=(25, 2)).astype(np.float32)
        t0 = time.perf_counter()
        done = False
        for a in actions:
            _, _, term, trunc, _ = env.step(a)
            n += 1
            if term or trunc:
                done = True
                break
        wall += time.perf_counter() - t0
        if done:
            env.reset(options=options)
    return n, wall
