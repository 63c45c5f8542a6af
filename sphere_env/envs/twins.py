"""The twins an environment steps: one per shell model and incline, built on first use.

Point and injected twins cache nothing heavy and keep one twin per (shell model, quantized
incline), least recently used first out. A hydroelastic environment whose randomization draws the
incline keeps one shared twin for every incline it can draw, moving its ground between episodes:
each hydroelastic twin caches up to :attr:`Twin.GEOMETRY_CACHE_SIZE` re-meshed shells (≈1.8 MB
each), so one twin per incline would multiply that memory.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from pathlib import Path
from typing import Any

from sphere_env.envs.kwargs import EnvKwargs
from sphere_env.params import PARAMETERS
from sphere_env.physics import InitialState, Twin, TwinConfig
from sphere_env.physics.admissibility import MAX_INITIAL_PENETRATION_M, ground_clearance_m
from sphere_env.physics.terrain import Terrain
from sphere_env.tasks.randomization import RandomizationSpec

#: Sampled inclines are rounded to this (terrain is geometry and shell kinematics, built per incline).
INCLINE_RESOLUTION_DEG = 1.0
MAX_TWINS = 12


def quantize_incline(incline_deg: float) -> float:
    return round(float(incline_deg) / INCLINE_RESOLUTION_DEG) * INCLINE_RESOLUTION_DEG


def shared_inclines(spec: RandomizationSpec, shell_model: str, incline_deg: float, meshcat: Any) -> tuple[float, ...]:
    """Inclines [deg] one hydroelastic twin serves: the env's and every 1° grid value ``spec`` can
    draw; empty unless the env's shell is hydroelastic, ``spec`` draws the incline and there is no
    Meshcat (its ground is drawn once)."""
    term = next((t for t in spec.terms if t.parameter == "incline_deg"), None)
    if shell_model != "hydroelastic" or meshcat is not None or term is None:
        return ()
    d, rec = term.distribution, PARAMETERS["incline_deg"]
    if d.kind == "fixed":
        values = [d.value]
    elif d.kind == "choice":
        values = list(d.values)
    elif d.kind == "uniform":
        values = range(math.floor(d.low), math.ceil(d.high) + 1)
    else:  # normal, clipped to the parameter's bounds
        values = range(math.floor(rec.low), math.ceil(rec.high) + 1)
    grid = {quantize_incline(rec.clip(float(v))) for v in values}
    return tuple(sorted(v for v in grid | {float(incline_deg)} if rec.contains(v)))


def drawn_shells(spec: RandomizationSpec) -> set[str]:
    """The shell models ``spec`` can draw (empty: none drawn, the env's own)."""
    for t in spec.terms:
        if t.parameter == "shell_model":
            d = t.distribution
            return {d.value} if d.kind == "fixed" else set(d.values)
    return set()


def largest(spec: RandomizationSpec, name: str) -> float:
    """The largest value a spec can give ``name`` (nominal when not randomized; a normal
    distribution is clipped to the registry bound; a schedule whose rate may be positive can
    reach the registry bound)."""
    for t in spec.terms:
        if t.parameter == name:
            d = t.distribution
            if t.mode == "schedule" and _may_rise(t.rate_per_s):
                return float(PARAMETERS[name].high)
            if d is None:
                return float(PARAMETERS[name].nominal)
            if d.kind == "fixed":
                return float(d.value)
            if d.kind == "uniform":
                return float(d.high)
            if d.kind == "choice":
                return max(float(v) for v in d.values)
            return float(PARAMETERS[name].high)
    return float(PARAMETERS[name].nominal)


def _may_rise(rate) -> bool:
    """Whether a schedule's rate distribution can draw a positive rate."""
    if rate.kind == "fixed":
        return rate.value > 0
    if rate.kind == "uniform":
        return rate.high > 0
    if rate.kind == "choice":
        return max(rate.values) > 0
    return True  # normal


def stability_problem(spec: RandomizationSpec, twins: list[Twin]) -> str | None:
    """Friction and injected shell torques are explicit: the largest friction scales ``spec`` can
    draw must not diverge at the time step of any of ``twins``; the first problem, or None."""
    scales = [
        largest(spec, name)
        for name in ("steer_friction_scale", "drive_friction_scale", "shell_stiffness_scale", "shell_damping_scale")
    ]
    for twin in twins:
        problem = twin.explicit_stability_problem(*scales)
        if problem:
            return problem
    return None


def twin_config(kw: EnvKwargs, calibration: str | Path | None) -> TwinConfig:
    """The :class:`~sphere_env.physics.TwinConfig` every twin of an environment starts from: its
    kwargs ``kw`` (the env's own shell model and incline) on free ground, with the shell
    ``calibration`` (a path or a shipped name); ground friction is a parameter (nominal 1).

    Built without a second check: :class:`~sphere_env.envs.kwargs.EnvKwargs` types every field
    it gives as :class:`~sphere_env.physics.TwinConfig` does (its friction models already
    resolved), and refused a bad value naming the kwarg."""
    steer_friction, drive_friction = kw.friction_model
    return TwinConfig.model_construct(
        fixture="free",
        shell_model=kw.shell_model,
        steer_friction=steer_friction,
        drive_friction=drive_friction,
        incline_deg=float(kw.incline_deg),
        ramp_length_m=kw.ramp_length_m,
        time_step_s=kw.time_step_s,
        ground_friction=1.0,
        calibration=calibration,
        pressure_extrapolation_kpa=kw.pressure_extrapolation_kpa,
        contact_approximation=kw.contact_approximation,
        calibration_drive_law=kw.calibration_drive_law,
    )


def check_above_ground(twin: Twin, init: InitialState, incline_deg: float, ramp_length_m: float | None) -> None:
    """Refuse an initial sphere centre more than MAX_INITIAL_PENETRATION_M inside the ground of
    ``incline_deg`` (``ValueError`` naming the option): the ground's geometry is needed, so this
    is the one check of ``initial_state`` the options' schema cannot make."""
    if init.position_m is None:
        return
    clearance = ground_clearance_m(Terrain(incline_deg, ramp_length_m), init.position_m)
    radius = twin.robot.radius_m
    if clearance < radius - MAX_INITIAL_PENETRATION_M:
        raise ValueError(
            f"field 'options.initial_state.position_m' = {tuple(init.position_m)!r} puts the sphere centre "
            f"{clearance:.3g} m from the ground (incline {incline_deg:g}°); allowed: at least "
            f"{radius - MAX_INITIAL_PENETRATION_M:.3g} m (shell radius {radius:.3g} m minus "
            f"{MAX_INITIAL_PENETRATION_M} m of penetration)"
        )


class TwinCache:
    """The twins of one environment.

    :param config: the :class:`~sphere_env.physics.TwinConfig` every twin of the env starts from
        (:func:`twin_config`); its ``shell_model`` is the env's own (the only one the shared twin
        serves), its ``incline_deg`` the env's own (where the shared twin starts). Each twin's
        incline and shell model replace those without a second check: the env drew them within
        their bounds (a 1° grid incline, a shell model of the spec's choices).
    :param meshcat: the env's Meshcat, or None.
    :param shared: the inclines the shared hydroelastic twin serves (:func:`shared_inclines`).
    """

    def __init__(self, config: TwinConfig, meshcat: Any = None, shared: tuple[float, ...] = ()):
        self._config, self._meshcat = config, meshcat
        self.shell_model = shell = config.shell_model
        self._twins: OrderedDict[tuple[str, float], Twin] = OrderedDict()
        self._shared = self._build(float(config.incline_deg), shared, shell) if len(shared) > 1 else None

    def _build(self, incline_deg: float, inclines_deg: tuple[float, ...], shell_model: str) -> Twin:
        """A twin of ``shell_model`` at ``incline_deg``; ``inclines_deg`` sorted, distinct and holding
        ``incline_deg`` (:func:`shared_inclines`), or empty."""
        update = {"incline_deg": incline_deg, "inclines_deg": inclines_deg, "shell_model": shell_model}
        return Twin(self._config.model_copy(update=update), meshcat=self._meshcat)

    def get(self, incline_deg: float, shell_model: str | None = None) -> Twin:
        """The twin for a shell model (default: the env's) and an incline: the shared twin if it has
        that incline (moved there), else the pair's own twin, built on first use (LRU, at most
        :data:`MAX_TWINS`)."""
        shell = shell_model or self.shell_model
        if self._shared is not None and shell == self.shell_model and incline_deg in self._shared.inclines_deg:
            return self._shared
        key = (shell, incline_deg)
        twin = self._twins.get(key)
        if twin is not None:
            self._twins.move_to_end(key)
            return twin
        twin = self._build(incline_deg, (), shell)
        self._twins[key] = twin
        if len(self._twins) > MAX_TWINS:
            self._twins.popitem(last=False)
        return twin

    def stability_problem(self, spec: RandomizationSpec, twin: Twin, incline_deg: float) -> str | None:
        """Friction and injected shell torques are explicit: the largest friction and shell scales
        ``spec`` can draw must not diverge at this time step, on ``twin`` and, when ``spec`` can
        draw it, on the injected shell at ``incline_deg`` (its drive damping adds to the
        friction's; the other shells add none); the first problem, or None."""
        twins = [twin]
        if self.shell_model != "injected" and "injected" in drawn_shells(spec):
            twins.append(self.get(incline_deg, "injected"))
        return stability_problem(spec, twins)

    def all(self) -> list[Twin]:
        return ([self._shared] if self._shared is not None else []) + list(self._twins.values())

    def clear(self) -> None:
        self._twins.clear()
        self._shared = None
