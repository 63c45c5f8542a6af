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

Spec formats accepted by :meth:`RandomizationSpec.parse` (the env kwarg ``randomization``): the
spec is the schema of its own mapping form, each parameter's entry a
:class:`~sphere_env.tasks.terms.Term` typed from its record (the presets' mappings are
:func:`preset`):

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
* a :class:`RandomizationSpec` (checked again as the mapping it is written as,
  :meth:`RandomizationSpec.as_data`, for the environment at hand).
"""

from __future__ import annotations

from typing import Any, Literal, Mapping

import numpy as np
from pydantic import Field, PrivateAttr, ValidationInfo, create_model, model_validator

from sphere_env.parameter import Parameter
from sphere_env.params import PARAMETERS as REGISTRY
from sphere_env.params import RANDOMIZABLE, ParameterSpace
from sphere_env.schemas import Schema, allowed, validate
from sphere_env.tasks.terms import PressureSchedule, Term, parameter_field, plain, term_words

#: The randomizable parameters' records (name, unit, nominal, bounds; :mod:`sphere_env.params`).
#: Pressure bounds come from the shell calibration: a :class:`~sphere_env.params.ParameterSpace`
#: fills them in (:meth:`RandomizationSpec.resolved`).
PARAMETERS: dict[str, Parameter] = {name: REGISTRY[name] for name in RANDOMIZABLE}
#: The preset names: a whole spec, or the ``base`` a mapping starts from.
PRESETS = ("off", "default", "full")


def preset(name: str, ramp: bool) -> dict[str, Any]:
    """A preset as the mapping it stands for (the incline only where there is a ramp)."""
    if name == "off":
        return {}
    out: dict[str, Any] = {"pressure_kpa": {"distribution": "uniform"}}
    if name == "full":
        out |= {
            "steer_friction_scale": [0.8, 1.2],
            "drive_friction_scale": [0.8, 1.2],
            "ground_friction": [0.7, 1.3],
            "payload_mass_kg": [0.0, 3.0],
            "payload_com_offset_m": [[-0.02] * 3, [0.02] * 3],
        }
        if ramp:
            out["incline_deg"] = [12.0, 20.0]
        out["pressure_schedule"] = {"rate_kpa_per_s": [-0.2, 0.0]}
    return out


#: One optional field per randomizable parameter, typed from its registry record.
_ParameterTerms = create_model(
    "_ParameterTerms",
    __base__=Schema,
    __module__=__name__,
    **{
        name: (parameter_field(REGISTRY[name]), Field(None, json_schema_extra=allowed(term_words(REGISTRY[name]))))
        for name in RANDOMIZABLE
    },
)


class RandomizationSpec(_ParameterTerms):
    """A set of terms, at most one per randomizable parameter (a field of that parameter's name,
    None when not drawn), and an optional pressure schedule; frozen. Loaded from its mapping
    form (module docstring) by :meth:`parse`: a preset to start from (``base``; once loaded its
    entries are the spec's own, and ``base`` reads ``off``), parameter entries over it and the
    pressure schedule (``null``: none, also over a preset's). :attr:`terms` lists the terms in the
    order they are drawn (a preset's first)."""

    base: Literal[PRESETS] = Field(
        "off",
        json_schema_extra=allowed(  # type: ignore[valid-type]
            f"a preset name {list(PRESETS)}: the whole spec, or the mapping's base"
        ),
    )
    pressure_schedule: PressureSchedule | None = Field(
        None, json_schema_extra=allowed("{rate_kpa_per_s: <entry>, delay_s: <s>} or null")
    )
    _order: tuple[str, ...] = PrivateAttr(())

    @model_validator(mode="wrap")
    @classmethod
    def _over_the_preset(cls, data: Any, handler, info: ValidationInfo) -> "RandomizationSpec":
        """The preset's entries first, the mapping's over them (an entry keeps the preset's place:
        terms are drawn in this order); records that order."""
        data = plain(data)
        if isinstance(data, Mapping) and data.get("base", "off") in PRESETS:
            ramp = (info.context or {}).get("ramp", True)
            pressure = data.get("pressure_kpa")
            if isinstance(pressure, Mapping) and pressure.get("mode") == "schedule":
                if data.get("pressure_schedule") is not None:
                    raise ValueError(
                        f"field 'pressure_schedule' = {data['pressure_schedule']!r}: 'pressure_kpa' has "
                        "mode 'schedule' already; allowed: one pressure schedule (null here, or another "
                        "mode for 'pressure_kpa')"
                    )
                data = {**data, "pressure_schedule": None}  # replaces a preset's
            data = {**preset(data.get("base", "off"), ramp), **data, "base": "off"}
        out = handler(data)
        out._order = tuple(k for k in data if k in RANDOMIZABLE and data[k] is not None)
        return out

    @model_validator(mode="after")
    def _incline_needs_a_ramp(self, info: ValidationInfo) -> "RandomizationSpec":
        term = self.incline_deg
        if not (info.context or {}).get("ramp", True) and term is not None and term.kind != "fixed":
            raise ValueError(
                f"field 'incline_deg.distribution' = {term.kind!r}: this environment has no "
                "ramp, so the incline cannot be randomized; allowed: 'fixed'"
            )
        return self

    @property
    def terms(self) -> tuple[Term, ...]:
        """The terms given, in the order they are drawn (a preset's first)."""
        return tuple(getattr(self, name) for name in self._order)

    @classmethod
    def parse(cls, spec: Any, ramp: bool = True, kwarg: str = "randomization") -> "RandomizationSpec":
        """A spec from any accepted format (module docstring; ``ramp``: the environment has one); a
        ``ValueError`` starting with ``<kwarg>:`` names the field, its value and what is allowed."""
        if spec is None:
            return cls()
        data = spec.as_data() if isinstance(spec, RandomizationSpec) else spec
        if isinstance(data, str):
            data = {"base": data}
        if not isinstance(data, Mapping):
            raise ValueError(
                f"{kwarg}: value {data!r} ({type(data).__name__}) is not a spec; allowed: None, a preset name "
                f"{list(PRESETS)}, a mapping of parameters to entries or a RandomizationSpec"
            )
        return validate(cls, data, kwarg, context={"ramp": ramp})

    def as_data(self) -> dict[str, Any]:
        """The mapping this spec is written as (every term in full, in order, and the schedule)."""
        sched = self.pressure_schedule
        return {
            **{t.parameter: t.as_data() for t in self.terms},
            "pressure_schedule": None if sched is None else sched.as_data(),
        }

    def with_entries(self, entries: Any, ramp: bool = True, kwarg: str = "randomization") -> "RandomizationSpec":
        """This spec with the parameters of ``entries`` (a mapping in the spec's own format, e.g.
        ``{"shell_model": "point"}``) drawn as given there instead; every other term and the
        pressure schedule kept. Validated like :meth:`parse`."""
        return RandomizationSpec.parse({**self.as_data(), **dict(entries)}, ramp, kwarg)

    def resolved(self, space: ParameterSpace, kwarg: str = "randomization") -> "RandomizationSpec":
        """The spec in ``space`` (the registry resolved against the calibration): a parameter whose
        bounds come from the context (``bounds_from``: the pressure) gets them as its uniform
        distribution's bounds when it gave none, and its values are checked against them (every
        other value was checked against the registry on loading); ``ValueError`` naming
        ``<kwarg>: field '<parameter>'`` otherwise."""
        changed = {}
        for t in self.terms:
            rec = space[t.parameter]
            if rec.bounds_from is None or t.kind is None:
                continue
            if t.kind == "uniform" and t.low is None:
                t = changed[t.parameter] = t.model_copy(update={"low": rec.low, "high": rec.high})
            values = {"fixed": [t.value], "uniform": [t.low, t.high], "choice": list(t.values or ())}
            for v in values.get(t.kind, []):
                rec.check(v, f"{kwarg}: field {t.parameter!r}")
        return self.model_copy(update=changed) if changed else self

    def sample(self, rng: np.random.Generator, which: str | None = None) -> dict[str, Any]:
        """Sample every term's value at reset (``which=None``), or only terms of one mode; a schedule
        without a draw of its own samples nothing. Fixed order."""
        return {
            t.parameter: t.sample(rng, PARAMETERS[t.parameter].size)
            for t in self.terms
            if t.kind is not None and (which is None or t.mode == which)
        }


def schedule_value(name: str, v0: float, rate_per_s: float, delay_s: float, t_s: float, space: ParameterSpace) -> float:
    """value(t) of a schedule of ``name``: ``v0`` + rate · max(t − delay_s, 0), clipped to the
    bounds of ``name`` in ``space``."""
    return space.clip(name, v0 + rate_per_s * max(t_s - delay_s, 0.0))


def schedule_pressure(p0_kpa: float, rate_kpa_per_s: float, delay_s: float, t_s: float, space: ParameterSpace) -> float:
    """p(t) of a :class:`~sphere_env.tasks.terms.PressureSchedule` [kPa], clipped to the pressure's
    bounds in ``space`` (the calibration range)."""
    return schedule_value("pressure_kpa", p0_kpa, rate_kpa_per_s, delay_s, t_s, space)
