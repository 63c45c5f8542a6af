"""Declarative domain randomization (Isaac Lab "event term" style), pure numpy.

A :class:`RandomizationSpec` says **what** is sampled (a parameter name), **when** (``reset``:
once per episode; ``interval``: again every ``interval_s`` seconds of sim time) and **from which
distribution**; an optional :class:`PressureSchedule` moves the pressure within an episode (a
slow leak or a pump). All sampling takes the env's ``np_random`` generator; nothing touches
global RNG state. Every sampled value is reported in the env's ``info["params"]``.

Parameters: the ``RANDOMIZABLE`` records of :mod:`sphere_env.params` (unit, nominal value when not
randomized, bounds): ``pressure_kpa`` (the calibration's nominal and range; hydroelastic: snapped
to the env's ``hydroelastic_pressure_step_kpa`` grid), ``steer_friction_scale``,
``drive_friction_scale``, ``ground_friction``, ``incline_deg`` (ramp tasks, reset only, sampled
values snap to 1°), ``payload_mass_kg``, ``payload_com_offset_m`` (3 components), and the sensing
and actuation faults the environment applies: ``observation_noise_scale``,
``action_latency_steps`` (reset only, whole numbers) and ``motor_torque_scale``. The
:class:`~sphere_env.tasks.events.EventManager` turns a spec into an episode's events.

Spec formats accepted by :meth:`RandomizationSpec.parse` (the env kwarg ``randomization``):

* ``"off"`` or ``None``: nothing sampled, every parameter nominal (evaluation).
* ``shell_model`` is categorical: a name (fixed), a list of names (drawn uniformly per reset) or
  ``{distribution: choice, values: [...]}``.
* ``"default"``: pressure ~ uniform over the calibration's range at each reset.
* ``"full"``: default plus friction scales U[0.8, 1.2], ground μ U[0.7, 1.3], payload
  U[0, 3] kg at offset U[−0.02, 0.02]³ m, incline U[12, 20]° (ramp tasks only) and a leak
  ``rate_kpa_per_s`` U[−0.2, 0].
* a mapping ``{parameter: entry, ..., "pressure_schedule": {...}, "base": "off"|"default"|"full"}``
  where ``entry`` is a number or 3-list (fixed), ``[low, high]`` (uniform per reset), or a
  dict ``{distribution: fixed|uniform|normal|choice, value|low,high|mean,std|values,
  mode: reset|interval, interval_s}``. Without ``base`` the mapping starts from ``"off"``.
  ``pressure_kpa: {distribution: uniform}`` without bounds means the calibration's range.
* a :class:`RandomizationSpec`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, Mapping

import numpy as np

from sphere_env.checks import finite_number
from sphere_env.params import PARAMETERS as REGISTRY
from sphere_env.params import RANDOMIZABLE, Parameter

#: The randomizable parameters' records (name, unit, nominal, bounds; :mod:`sphere_env.params`).
#: Pressure bounds come from the shell calibration.
PARAMETERS: dict[str, Parameter] = {name: REGISTRY[name] for name in RANDOMIZABLE}
DISTRIBUTIONS = ("fixed", "uniform", "normal", "choice")
MODES = ("reset", "interval")
#: Parameters that change only between episodes (terrain): no ``interval`` mode.
RESET_ONLY = tuple(name for name, rec in PARAMETERS.items() if rec.changes == "reset")


def _vec(kwarg: str, value: Any, size: int) -> tuple[float, ...] | float:
    if size == 1:
        return finite_number(kwarg, value)
    if not isinstance(value, (list, tuple, np.ndarray)) or len(value) != size:
        raise ValueError(f"{kwarg}: value {value!r} must be {size} numbers")
    return tuple(finite_number(kwarg, v) for v in value)


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
    """What (``parameter``), when (``mode``, ``interval_s``) and from which ``distribution``."""

    parameter: str
    distribution: Distribution
    mode: str = "reset"
    interval_s: float | None = None


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

    # ---- presets ------------------------------------------------------------------------------
    @classmethod
    def preset(cls, name: str, ramp: bool = True) -> "RandomizationSpec":
        if name == "off":
            return cls()
        pressure = Term("pressure_kpa", Distribution("uniform"))
        if name == "default":
            return cls((pressure,))
        if name == "full":
            terms = [
                pressure,
                Term("steer_friction_scale", Distribution("uniform", low=0.8, high=1.2)),
                Term("drive_friction_scale", Distribution("uniform", low=0.8, high=1.2)),
                Term("ground_friction", Distribution("uniform", low=0.7, high=1.3)),
                Term("payload_mass_kg", Distribution("uniform", low=0.0, high=3.0)),
                Term("payload_com_offset_m", Distribution("uniform", low=(-0.02,) * 3, high=(0.02,) * 3)),
            ]
            if ramp:
                terms.append(Term("incline_deg", Distribution("uniform", low=12.0, high=20.0)))
            return cls(tuple(terms), PressureSchedule(Distribution("uniform", low=-0.2, high=0.0)))
        raise ValueError(f"randomization: unknown preset {name!r}; allowed: ['off', 'default', 'full']")

    # ---- parsing --------------------------------------------------------------------------------
    @classmethod
    def parse(cls, spec: Any, ramp: bool = True, kwarg: str = "randomization") -> "RandomizationSpec":
        """Build and validate a spec from any accepted format (module docstring)."""
        if spec is None:
            return cls()
        if isinstance(spec, RandomizationSpec):
            out = spec
        elif isinstance(spec, str):
            out = cls.preset(spec, ramp)
        elif isinstance(spec, Mapping):
            spec = dict(spec)
            base = spec.pop("base", "off")
            if not isinstance(base, str):
                raise ValueError(f"{kwarg}: 'base' = {base!r} must be 'off', 'default' or 'full'")
            out = cls.preset(base, ramp)
            terms = {t.parameter: t for t in out.terms}
            schedule = out.pressure_schedule
            for name, entry in spec.items():
                if name == "pressure_schedule":
                    schedule = None if entry is None else _parse_schedule(entry, f"{kwarg}.pressure_schedule")
                    continue
                if name not in PARAMETERS:
                    raise ValueError(
                        f"{kwarg}: unknown parameter {name!r}; allowed: {sorted(PARAMETERS) + ['pressure_schedule', 'base']}"
                    )
                terms[name] = _parse_term(name, entry, f"{kwarg}.{name}")
            out = cls(tuple(terms.values()), schedule)
        else:
            raise ValueError(f"{kwarg}: value {spec!r} must be None, a preset name, a mapping or a RandomizationSpec")
        out._validate(ramp, kwarg)
        return out

    def _validate(self, ramp: bool, kwarg: str) -> None:
        seen = set()
        for t in self.terms:
            where = f"{kwarg}.{t.parameter}"
            if t.parameter not in PARAMETERS:
                raise ValueError(f"{kwarg}: unknown parameter {t.parameter!r}; allowed: {sorted(PARAMETERS)}")
            if t.parameter in seen:
                raise ValueError(f"{where}: given twice")
            seen.add(t.parameter)
            if t.mode not in MODES:
                raise ValueError(f"{where}.mode: value {t.mode!r}; allowed: {list(MODES)}")
            if t.mode == "interval":
                if t.parameter in RESET_ONLY:
                    raise ValueError(f"{where}.mode: 'interval' not allowed for {t.parameter} (changes the terrain); use 'reset'")
                if t.interval_s is None or not finite_number(f"{where}.interval_s", t.interval_s) > 0:
                    raise ValueError(f"{where}.interval_s: value {t.interval_s!r} must be > 0 s for mode 'interval'")
            if t.parameter == "incline_deg" and not ramp and t.distribution.kind != "fixed":
                raise ValueError(f"{where}: this environment has no ramp; incline cannot be randomized")
            rec = PARAMETERS[t.parameter]
            bounds = None if t.parameter == "pressure_kpa" else rec
            _check_distribution(where, t.distribution, rec.size, bounds, natural_range=t.parameter == "pressure_kpa")
        if self.pressure_schedule is not None:
            where = f"{kwarg}.pressure_schedule"
            sched = self.pressure_schedule
            if not isinstance(sched, PressureSchedule) or not isinstance(sched.rate_kpa_per_s, Distribution):
                raise ValueError(f"{where}: value {sched!r} must be a PressureSchedule of a rate Distribution")
            _check_distribution(f"{where}.rate_kpa_per_s", sched.rate_kpa_per_s, 1, None, natural_range=False)
            if not finite_number(f"{where}.delay_s", sched.delay_s, ">= 0 s") >= 0:
                raise ValueError(f"{where}.delay_s: value {sched.delay_s!r} must be >= 0 s")

    def resolved(self, pressure_range_kpa: tuple[float, float], kwarg: str = "randomization") -> "RandomizationSpec":
        """Fill pressure bounds from the calibration and check pressures lie in its range."""
        lo, hi = pressure_range_kpa
        terms = []
        for t in self.terms:
            d = t.distribution
            if t.parameter == "pressure_kpa":
                if d.kind == "uniform" and d.low is None:
                    d = replace(d, low=lo, high=hi)
                vals = {"fixed": [d.value], "uniform": [d.low, d.high], "choice": list(d.values)}.get(d.kind, [])
                for v in vals:
                    if not lo <= float(v) <= hi:
                        raise ValueError(
                            f"{kwarg}.pressure_kpa: value {v!r} outside the calibrated range [{lo}, {hi}] kPa"
                        )
                t = replace(t, distribution=d)
            terms.append(t)
        return replace(self, terms=tuple(terms))

    def sample(self, rng: np.random.Generator, which: str | None = None) -> dict[str, Any]:
        """Sample every term (``which=None``), or only terms of one mode. Fixed order."""
        out = {}
        for t in self.terms:
            if which is None or t.mode == which:
                out[t.parameter] = t.distribution.sample(rng, PARAMETERS[t.parameter].size)
        return out


def clip_parameter(name: str, value, pressure_range_kpa: tuple[float, float]):
    """Clip a (normal-)sampled value into the parameter's allowed bounds."""
    if name == "pressure_kpa":
        lo, hi = pressure_range_kpa
        return min(max(float(value), lo), hi)
    rec = PARAMETERS[name]
    if rec.choices:
        return value
    if isinstance(value, tuple):
        return tuple(rec.clip(v) for v in value)
    return rec.clip(float(value))


def _check_distribution(where: str, d: Distribution, size: int, bounds: Parameter | None, natural_range: bool) -> None:
    """Refuse a distribution numpy could not sample or that leaves ``bounds``: unknown kind,
    non-finite numbers, uniform without both bounds (unless ``natural_range``: pressure's is the
    calibration's) or with low > high, normal with std < 0, empty choice."""
    if d.kind not in DISTRIBUTIONS:
        raise ValueError(f"{where}.distribution: value {d.kind!r}; allowed: {list(DISTRIBUTIONS)}")
    if bounds is not None and bounds.choices:  # a categorical parameter: a name, or a choice of names
        if d.kind not in ("fixed", "choice"):
            raise ValueError(f"{where}.distribution: value {d.kind!r}; allowed for {bounds.name}: ['fixed', 'choice']")
        values = [d.value] if d.kind == "fixed" else list(d.values)
        if not values:
            raise ValueError(f"{where}.values: value {d.values!r}; choice needs a non-empty list of values")
        for v in values:
            if not bounds.contains(v):
                raise ValueError(f"{where}: value {v!r}; allowed: {bounds.allowed}")
        return
    if d.kind == "fixed":
        _check_bounds(where, _vec(where, d.value, size), bounds)
    elif d.kind == "uniform":
        if (d.low is None) != (d.high is None) or (d.low is None and not natural_range):
            raise ValueError(f"{where}: uniform needs both 'low' and 'high' (got low={d.low!r}, high={d.high!r})")
        if d.low is not None:
            lo, hi = _vec(f"{where}.low", d.low, size), _vec(f"{where}.high", d.high, size)
            if np.any(np.asarray(lo) > np.asarray(hi)):
                raise ValueError(f"{where}: uniform low {d.low!r} > high {d.high!r}; allowed: low <= high")
            _check_bounds(where, lo, bounds)
            _check_bounds(where, hi, bounds)
    elif d.kind == "normal":
        _vec(f"{where}.mean", d.mean, size)
        if np.any(np.asarray(_vec(f"{where}.std", d.std, size)) < 0):
            raise ValueError(f"{where}.std: value {d.std!r} must be >= 0")
    else:
        if not isinstance(d.values, (tuple, list)) or not d.values:
            raise ValueError(f"{where}.values: value {d.values!r}; choice needs a non-empty list of values")
        for v in d.values:
            _check_bounds(where, _vec(f"{where}.values", v, size), bounds)


def _check_bounds(where: str, value, record: Parameter | None) -> None:
    if record is None:
        return
    for v in (value if isinstance(value, tuple) else (value,)):
        if not record.contains(v):
            raise ValueError(f"{where}: value {v!r} outside allowed {record.allowed}")
        if record.integer and v != round(v):
            raise ValueError(f"{where}: value {v!r} must be a whole number within {record.allowed}")


def _parse_distribution(entry: Any, size: int, where: str) -> tuple[Distribution, str, float | None]:
    if isinstance(entry, Mapping):
        e = dict(entry)
        kind = e.pop("distribution", "uniform" if "low" in e or "high" in e else "fixed")
        mode = e.pop("mode", "reset")
        interval = e.pop("interval_s", None)
        allowed = {"value", "low", "high", "mean", "std", "values"}
        for k in e:
            if k not in allowed:
                raise ValueError(f"{where}: unknown field {k!r}; allowed: {sorted(allowed | {'distribution', 'mode', 'interval_s'})}")
        vals = e.get("values", ())
        if not isinstance(vals, (list, tuple)):
            raise ValueError(f"{where}.values: value {vals!r} must be a list of values")
        d = Distribution(kind, e.get("value"), e.get("low"), e.get("high"), e.get("mean"), e.get("std"),
                         tuple(tuple(v) if isinstance(v, list) else v for v in vals))
        if kind == "fixed":
            d = replace(d, value=_vec(where, d.value, size))
        return d, mode, interval
    if isinstance(entry, (list, tuple)) and size == 1:
        if len(entry) != 2:
            raise ValueError(f"{where}: value {entry!r} must be a number or [low, high]")
        return Distribution("uniform", low=finite_number(where, entry[0]), high=finite_number(where, entry[1])), "reset", None
    if isinstance(entry, (list, tuple)) and size == 3 and len(entry) == 2 and all(isinstance(x, (list, tuple)) for x in entry):
        return Distribution("uniform", low=_vec(where, entry[0], 3), high=_vec(where, entry[1], 3)), "reset", None
    return Distribution("fixed", value=_vec(where, entry, size)), "reset", None


def _parse_term(name: str, entry: Any, where: str) -> Term:
    if PARAMETERS[name].choices:  # a categorical parameter: a name, a list of names, or a mapping
        if isinstance(entry, str):
            return Term(name, Distribution("fixed", value=entry))
        if isinstance(entry, (list, tuple)):
            return Term(name, Distribution("choice", values=tuple(entry)))
        if isinstance(entry, Mapping):
            e = dict(entry)
            kind = e.pop("distribution", "choice" if "values" in e else "fixed")
            mode, interval = e.pop("mode", "reset"), e.pop("interval_s", None)
            bad = [k for k in e if k not in ("value", "values")]
            if bad:
                raise ValueError(f"{where}: unknown field {bad[0]!r}; allowed: ['distribution', 'mode', 'value', 'values']")
            vals = e.get("values", ())
            if not isinstance(vals, (list, tuple)):
                raise ValueError(f"{where}.values: value {vals!r} must be a list of names")
            return Term(name, Distribution(kind, value=e.get("value"), values=tuple(vals)), mode, interval)
        raise ValueError(f"{where}: value {entry!r}; allowed: a name or a list of names from {PARAMETERS[name].allowed}")
    d, mode, interval = _parse_distribution(entry, PARAMETERS[name].size, where)
    return Term(name, d, mode, interval)


def _parse_schedule(entry: Any, where: str) -> PressureSchedule:
    if isinstance(entry, PressureSchedule):
        return entry
    if not isinstance(entry, Mapping) or "rate_kpa_per_s" not in entry:
        raise ValueError(f"{where}: value {entry!r} must be a mapping with 'rate_kpa_per_s' (and optional 'delay_s')")
    for k in entry:
        if k not in ("rate_kpa_per_s", "delay_s"):
            raise ValueError(f"{where}: unknown field {k!r}; allowed: ['delay_s', 'rate_kpa_per_s']")
    d, _, _ = _parse_distribution(entry["rate_kpa_per_s"], 1, f"{where}.rate_kpa_per_s")
    delay = finite_number(f"{where}.delay_s", entry.get("delay_s", 0.0))
    if delay < 0:
        raise ValueError(f"{where}.delay_s: value {delay!r} must be >= 0 s")
    return PressureSchedule(d, delay)


def schedule_pressure(p0_kpa: float, rate_kpa_per_s: float, delay_s: float, t_s: float,
                      pressure_range_kpa: tuple[float, float]) -> float:
    """p(t) of a :class:`PressureSchedule` [kPa], clipped to the calibration range."""
    lo, hi = pressure_range_kpa
    p = p0_kpa + rate_kpa_per_s * max(t_s - delay_s, 0.0)
    return min(max(p, lo), hi)
