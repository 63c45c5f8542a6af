"""Declarative domain randomization (Isaac Lab "event term" style), pure numpy.

A :class:`RandomizationSpec` says **what** is sampled (a parameter name), **when** (``reset``:
once per episode; ``interval``: again every ``interval_s`` seconds of sim time; ``schedule``: a
value that moves at a rate drawn once per episode, value(t) = value at reset + rate ·
max(t − delay_s, 0), clipped to the parameter's bounds) and **from which distribution**; the
pressure's schedule may also be given as a :class:`PressureSchedule` (a slow leak or a pump). All
sampling takes the env's ``np_random`` generator; nothing touches global RNG state. Every sampled
value is reported in the env's ``info["params"]``.

Parameters: the ``RANDOMIZABLE`` records of :mod:`sphere_env.params` (unit, nominal value when not
randomized, bounds, whether it may change within an episode; listed in ``docs/envs.md``, generated
from the registry). The pressure's nominal value and range are the calibration's (hydroelastic:
values snap to the env's ``hydroelastic_pressure_step_kpa`` grid); drawn inclines snap to 1°; a
parameter that changes only between episodes takes mode ``reset`` only; a numeric scalar one
(``Parameter.schedulable``) also takes ``schedule``. The
:class:`~sphere_env.tasks.events.EventManager` turns a spec into an episode's events.

Spec formats accepted by :meth:`RandomizationSpec.parse` (the env kwarg ``randomization``), all
checked by one schema, :mod:`sphere_env.schemas.randomization` (the presets' mappings are its
:func:`~sphere_env.schemas.randomization.preset`):

* ``"off"`` or ``None``: nothing sampled, every parameter nominal (evaluation).
* ``shell_model`` is categorical: a name (fixed), a list of names (drawn uniformly per reset) or
  ``{distribution: fixed|choice, value|values}``.
* ``"default"``: pressure ~ uniform over the calibration's range at each reset.
* ``"full"``: default plus friction scales U[0.8, 1.2], ground μ U[0.7, 1.3], payload
  U[0, 3] kg at offset U[−0.02, 0.02]³ m, incline U[12, 20]° (ramp tasks only) and a leak
  ``rate_kpa_per_s`` U[−0.2, 0].
* a mapping ``{parameter: entry, ..., "pressure_schedule": {...}, "base": "off"|"default"|"full"}``
  where ``entry`` is a number or 3-list (fixed), ``[low, high]`` (uniform per reset; a vector's
  ``[[low...], [high...]]``), or a dict ``{distribution: fixed|uniform|normal|choice,
  value|low,high|mean,std|values, mode: reset|interval|schedule, interval_s, rate_per_s,
  delay_s}`` holding only its distribution's fields (``interval_s`` only with mode ``interval``;
  ``rate_per_s``, an entry without mode drawn once per episode, and ``delay_s`` >= 0 only with mode
  ``schedule``, which may leave out the distribution: the schedule then starts from the nominal
  value; without ``distribution``: the one whose fields are given). Without ``base`` the mapping
  starts from ``"off"``; its entries replace the preset's. ``pressure_kpa: {distribution:
  uniform}`` without bounds means the calibration's range. ``pressure_schedule``:
  ``{rate_kpa_per_s: entry without mode, delay_s}`` or ``null`` (none); ``pressure_kpa`` with mode
  ``schedule`` replaces a preset's ``pressure_schedule`` and is refused beside one given with it.
* a :class:`RandomizationSpec` (checked as the mapping it would be written as).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from sphere_env.params import PARAMETERS as REGISTRY
from sphere_env.params import RANDOMIZABLE, Parameter, ParameterSpace
from sphere_env.schemas.randomization import SpecInput, load_spec

#: The randomizable parameters' records (name, unit, nominal, bounds; :mod:`sphere_env.params`).
#: Pressure bounds come from the shell calibration: a :class:`~sphere_env.params.ParameterSpace`
#: fills them in (:meth:`RandomizationSpec.resolved`).
PARAMETERS: dict[str, Parameter] = {name: REGISTRY[name] for name in RANDOMIZABLE}


@dataclass(frozen=True)
class Distribution:
    """One distribution. Scalars, or tuples for vector parameters (sampled per component).

    ``fixed``: ``value``; ``uniform``: ``low``, ``high`` (``None`` = the parameter's natural range,
    only for pressure: the calibration range); ``normal``: ``mean``, ``std`` (clipped to the
    parameter's bounds); ``choice``: ``values``.
    """

    kind: str = "fixed"
    value: Any = None
    low: Any = None
    high: Any = None
    mean: Any = None
    std: Any = None
    values: tuple = ()

    def sample(self, rng: np.random.Generator, size: int) -> float | tuple[float, ...]:
        if self.kind == "fixed":
            return self.value
        if self.kind == "uniform":
            x = rng.uniform(self.low, self.high, size=size)
        elif self.kind == "normal":
            x = rng.normal(self.mean, self.std, size=size)
        else:  # choice
            return self.values[int(rng.integers(len(self.values)))]
        return float(x[0]) if size == 1 else tuple(float(v) for v in x)


@dataclass(frozen=True)
class Term:
    """What (``parameter``), when (``mode``, ``interval_s``) and from which ``distribution``.

    Mode ``schedule``: value(t) = value at reset + rate · max(t − ``delay_s``, 0), clipped to the
    parameter's bounds, the rate drawn once per episode from ``rate_per_s``; ``distribution`` None
    means the value at reset is not drawn (the nominal value, or a reset option)."""

    parameter: str
    distribution: Distribution | None
    mode: str = "reset"
    interval_s: float | None = None
    rate_per_s: Distribution | None = None
    delay_s: float = 0.0


@dataclass(frozen=True)
class PressureSchedule:
    """Pressure within an episode: p(t) = clip(p₀ + rate · max(t − delay_s, 0)) to the
    calibration range, p₀ the episode's (sampled) pressure. ``rate_kpa_per_s`` < 0 is a leak.
    ``rate_kpa_per_s`` is a :class:`Distribution` sampled per reset."""

    rate_kpa_per_s: Distribution
    delay_s: float = 0.0


@dataclass(frozen=True)
class RandomizationSpec:
    """A set of terms (at most one per parameter) and an optional pressure schedule."""

    terms: tuple[Term, ...] = ()
    pressure_schedule: PressureSchedule | None = None

    @classmethod
    def parse(cls, spec: Any, ramp: bool = True, kwarg: str = "randomization") -> "RandomizationSpec":
        """Build and validate a spec from any accepted format (module docstring) through its schema
        (:mod:`sphere_env.schemas.randomization`; ``ramp``: the environment has one); a
        ``ValueError`` starting with ``<kwarg>:`` names the field, its value and what is allowed."""
        if spec is None:
            return cls()
        data = _as_data(spec, kwarg) if isinstance(spec, RandomizationSpec) else spec
        return _from_schema(load_spec(data, ramp, kwarg))

    def with_entries(self, entries: Any, ramp: bool = True, kwarg: str = "randomization") -> "RandomizationSpec":
        """This spec with the parameters of ``entries`` (a mapping in the spec's own format, e.g.
        ``{"shell_model": "point"}``) drawn as given there instead; every other term and the
        pressure schedule kept. Validated like :meth:`parse`."""
        data = _as_data(self, kwarg)
        data.update(dict(entries))
        return RandomizationSpec.parse(data, ramp, kwarg)

    def resolved(self, space: ParameterSpace, kwarg: str = "randomization") -> "RandomizationSpec":
        """The spec in ``space`` (the registry resolved against the calibration): a parameter whose
        bounds come from the context (``bounds_from``: the pressure) gets them as its uniform
        distribution's bounds when it gave none, and its values are checked against them (the
        schema checked every other value against the registry already); ``ValueError`` naming
        ``<kwarg>: field '<parameter>'`` otherwise."""
        terms = []
        for t in self.terms:
            d, rec = t.distribution, space[t.parameter]
            if rec.bounds_from is not None and d is not None:
                if d.kind == "uniform" and d.low is None:
                    d = replace(d, low=rec.low, high=rec.high)
                vals = {"fixed": [d.value], "uniform": [d.low, d.high], "choice": list(d.values)}.get(d.kind, [])
                for v in vals:
                    rec.check(v, f"{kwarg}: field {t.parameter!r}")
                t = replace(t, distribution=d)
            terms.append(t)
        return replace(self, terms=tuple(terms))

    def sample(self, rng: np.random.Generator, which: str | None = None) -> dict[str, Any]:
        """Sample every term's value at reset (``which=None``), or only terms of one mode; a schedule
        without a draw of its own samples nothing. Fixed order."""
        out = {}
        for t in self.terms:
            if t.distribution is not None and (which is None or t.mode == which):
                out[t.parameter] = t.distribution.sample(rng, PARAMETERS[t.parameter].size)
        return out


def _from_schema(spec: SpecInput) -> RandomizationSpec:
    """A validated spec as the dataclasses the event manager reads (vectors as tuples)."""
    sched = spec.pressure_schedule
    return RandomizationSpec(
        tuple(
            Term(
                name,
                None if entry.distribution is None else _distribution(entry),
                entry.mode,
                entry.interval_s,
                None if entry.rate_per_s is None else _distribution(entry.rate_per_s),
                entry.delay_s or 0.0,
            )
            for name, entry in spec.entries()
        ),
        None if sched is None else PressureSchedule(_distribution(sched.rate_kpa_per_s), sched.delay_s),
    )


def _distribution(draw) -> Distribution:
    """A validated draw (:class:`sphere_env.schemas.randomization.Draw`) as a :class:`Distribution`."""

    def frozen(v):
        return tuple(v) if isinstance(v, list) else v

    value, low, high, mean, std = (frozen(getattr(draw, k, None)) for k in ("value", "low", "high", "mean", "std"))
    return Distribution(draw.distribution, value, low, high, mean, std, tuple(frozen(v) for v in draw.values or ()))


def _as_data(spec: RandomizationSpec, kwarg: str) -> dict[str, Any]:
    """A spec object as the mapping it would be written as, so that the schema checks it like one."""
    out: dict[str, Any] = {}
    for t in spec.terms:
        if t.parameter in out:
            raise ValueError(f"{kwarg}: field {t.parameter!r} is given twice; allowed: one term per parameter")
        timing = {} if t.interval_s is None else {"interval_s": t.interval_s}
        if t.rate_per_s is not None:
            timing["rate_per_s"] = _draw_data(t.rate_per_s)
        if t.delay_s or t.mode == "schedule":
            timing["delay_s"] = t.delay_s
        draw = {} if t.distribution is None else _draw_data(t.distribution)
        out[t.parameter] = {**draw, "mode": t.mode, **timing}
    sched = spec.pressure_schedule
    if isinstance(sched, PressureSchedule):
        out["pressure_schedule"] = {"rate_kpa_per_s": _draw_data(sched.rate_kpa_per_s), "delay_s": sched.delay_s}
    elif sched is not None:
        out["pressure_schedule"] = sched  # refused by the schema, named
    return out


def _draw_data(d: Any) -> Any:
    """A :class:`Distribution` as its mapping (only the fields it sets); anything else unchanged."""
    if not isinstance(d, Distribution):
        return d
    fields = {
        "value": d.value,
        "low": d.low,
        "high": d.high,
        "mean": d.mean,
        "std": d.std,
        "values": d.values if d.values or d.kind == "choice" else None,
    }
    return {"distribution": d.kind, **{k: v for k, v in fields.items() if v is not None}}


def schedule_value(name: str, v0: float, rate_per_s: float, delay_s: float, t_s: float, space: ParameterSpace) -> float:
    """value(t) of a schedule of ``name``: ``v0`` + rate · max(t − delay_s, 0), clipped to the
    bounds of ``name`` in ``space``."""
    return space.clip(name, v0 + rate_per_s * max(t_s - delay_s, 0.0))


def schedule_pressure(p0_kpa: float, rate_kpa_per_s: float, delay_s: float, t_s: float, space: ParameterSpace) -> float:
    """p(t) of a :class:`PressureSchedule` [kPa], clipped to the pressure's bounds in ``space``
    (the calibration range)."""
    return schedule_value("pressure_kpa", p0_kpa, rate_kpa_per_s, delay_s, t_s, space)
