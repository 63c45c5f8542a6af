"""The randomization spec's typed schema: every form the ``randomization`` kwarg takes as data.

:func:`load_spec` validates a preset name or a mapping (the formats of
:mod:`sphere_env.tasks.randomization`) against :class:`SpecInput`: an unknown key, a value of the
wrong type (a string or a bool is never a number), a value outside its parameter's bounds and a
distribution without the fields it needs are refused as ``<kwarg>: field '<path>' = <value>:
<problem>; allowed: <what>``. Each parameter's field types (bounds, whole numbers, vector size,
categorical names) come from its record in :mod:`sphere_env.params`. Two rules read the
environment from the validation context: without a ramp the incline cannot be randomized, and a
parameter that changes only between episodes (``changes == "reset"`` in the registry) takes no
``interval`` mode.

Every parameter entry is validated into a :class:`Draw` given in full (a number becomes
``{distribution: fixed, value: ...}``, ``[low, high]`` a uniform one, a list of names a choice), so
that :class:`~sphere_env.tasks.randomization.RandomizationSpec` is built from one form.
"""

from __future__ import annotations

from typing import Annotated, Any, ClassVar, Literal, Mapping, Optional, Union

import numpy as np
from pydantic import (
    AfterValidator,
    BeforeValidator,
    Discriminator,
    Field,
    PrivateAttr,
    Tag,
    ValidationInfo,
    create_model,
    model_validator,
)

from sphere_env.params import PARAMETERS as REGISTRY
from sphere_env.params import RANDOMIZABLE, Parameter, schedule_rate
from sphere_env.schemas import Schema, _integral, _ordered, allowed, number, validate

#: The preset names: a whole spec, or the ``base`` a mapping starts from.
PRESETS = ("off", "default", "full")
#: The fields each distribution takes.
DISTRIBUTIONS: dict[str, tuple[str, ...]] = {
    "fixed": ("value",),
    "uniform": ("low", "high"),
    "normal": ("mean", "std"),
    "choice": ("values",),
}
MODES = ("reset", "interval", "schedule")
#: Parameters whose uniform distribution may leave out both bounds: those whose bounds come from a
#: context (``bounds_from``; the pressure: the shell calibration's range), filled in by
#: ``RandomizationSpec.resolved``.
NATURAL_RANGE = tuple(name for name, rec in REGISTRY.items() if rec.bounds_from is not None)
#: The registry record of the pressure schedule's rate (drawn once per episode).
RATE = "pressure_rate_kpa_per_s"


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


# ---- one parameter's values ------------------------------------------------------------------------
def _scalar(rec: Parameter, bounded: bool = True) -> Any:
    """One value of ``rec``: a name, a whole number or a finite number (within its bounds)."""
    if rec.choices:
        return Literal[rec.choices]  # type: ignore[valid-type]
    limits = {}
    if bounded and rec.low is not None:
        limits["gt" if rec.low_open else "ge"] = rec.low
    if bounded and rec.high is not None:
        limits["lt" if rec.high_open else "le"] = rec.high
    if rec.integer:
        return Annotated[int, BeforeValidator(_integral), Field(**limits)]
    return Annotated[float, Field(allow_inf_nan=False, **limits)]


def _value(rec: Parameter, scalar: Any) -> Any:
    """``scalar``, or a list of ``rec.size`` of them for a vector parameter."""
    return scalar if rec.size == 1 else Annotated[list[scalar], Field(min_length=rec.size, max_length=rec.size)]


def _words(rec: Parameter) -> str:
    """What one value of ``rec`` may be, in words."""
    if rec.choices:
        return f"one of {rec.allowed}"
    if rec.low is None and rec.high is None:
        one = f"a finite number [{rec.unit}]"
    else:
        one = f"{'an integer' if rec.integer else 'a finite number'} within {rec.allowed}"
    return one if rec.size == 1 else f"{rec.size} numbers, each {one}"


def fixed_value(rec: Parameter) -> Any:
    """The type of one fixed value of ``rec`` (a ``reset`` option): a value as an entry's value form
    gives it (a tuple, a numpy array or numpy numbers read as plain data), never a distribution."""
    return Annotated[
        _value(rec, _scalar(rec)),
        BeforeValidator(_plain),
        Field(json_schema_extra=allowed(f"a fixed value: {_words(rec)}")),
    ]


#: The uniform distribution's bounds: low <= high (each component of a vector).
_low_high = _ordered(strict=False)


# ---- a distribution given in full ------------------------------------------------------------------
class Draw(Schema):
    """One distribution given in full: ``distribution`` (when left out: the one whose fields are
    given, else ``fixed``) and the fields it takes (:data:`DISTRIBUTIONS`), nothing else. Each
    parameter's subclass (:func:`draw_model`) types the fields from the parameter's record."""

    #: uniform may leave out both bounds (:data:`NATURAL_RANGE`)
    natural_range: ClassVar[bool] = False

    @model_validator(mode="before")
    @classmethod
    def _infer_distribution(cls, data: Any) -> Any:
        if isinstance(data, Mapping) and "distribution" not in data:
            given = [kind for kind, fields in DISTRIBUTIONS.items() if any(f in data for f in fields)]
            if not given and data.get("mode") == "schedule" and "mode" in cls.model_fields:
                return data  # no draw: the schedule starts from the nominal value (or a reset option)
            if len(given) > 1:
                raise ValueError(
                    f"field 'distribution' is missing: the fields given belong to {given}; allowed: "
                    "the fields of one distribution, or 'distribution' naming it"
                )
            data = {**data, "distribution": given[0] if given else "fixed"}
        return data

    @model_validator(mode="after")
    def _fields_of_the_distribution(self) -> "Draw":
        kind = self.distribution
        if kind is None:  # an entry's schedule without a draw (checked by the entry)
            return self
        takes = DISTRIBUTIONS[kind]
        others = {k for fields in DISTRIBUTIONS.values() for k in fields} - set(takes)
        for key in sorted(others):
            if getattr(self, key, None) is not None:
                raise ValueError(
                    f"field {key!r} is not used by distribution {kind!r}; allowed: "
                    f"{sorted(set(type(self).model_fields) - others)}"
                )
        if kind == "uniform" and self.low is None and self.high is None and self.natural_range:
            return self  # the calibration's range
        for key in takes:
            if getattr(self, key) is None:
                need = "uniform needs both 'low' and 'high'" if kind == "uniform" else f"{kind!r} needs it"
                raise ValueError(f"field {key!r} is missing: {need}")
        if kind == "uniform":
            _low_high((self.low, self.high))
        return self


class Entry(Draw):
    """A parameter's entry given in full: a :class:`Draw`, and when it is drawn: at every ``reset``,
    every ``interval_s`` seconds of sim time (``interval``), or at reset with a rate of change
    ``rate_per_s`` (itself a draw, once per episode) that moves the value after ``delay_s``
    (``schedule``; without a draw of its own the schedule starts from the nominal value)."""

    @model_validator(mode="after")
    def _mode_fields(self) -> "Entry":
        mode = self.mode
        if mode == "interval" and self.interval_s is None:
            raise ValueError("field 'interval_s' is missing: mode 'interval' needs a period > 0 s")
        if mode == "schedule" and self.rate_per_s is None:
            raise ValueError(
                "field 'rate_per_s' is missing: mode 'schedule' needs a rate of change, drawn once per episode"
            )
        for key, owner in (("interval_s", "interval"), ("rate_per_s", "schedule"), ("delay_s", "schedule")):
            if mode != owner and getattr(self, key) is not None:
                value = getattr(self, key)
                if isinstance(value, Draw):  # as given: a number, or the distribution's mapping
                    value = value.value if value.distribution == "fixed" else value.model_dump(exclude_none=True)
                raise ValueError(
                    f"field {key!r} = {value!r} is only for mode {owner!r}; allowed: leave it out for mode {mode!r}"
                )
        if self.distribution is None and mode != "schedule":
            raise ValueError(
                f"field 'distribution' = None: only mode 'schedule' may leave out the draw; allowed: "
                f"{list(DISTRIBUTIONS)}"
            )
        return self


def draw_model(rec: Parameter, entry: bool = True) -> type[Draw]:
    """The full form of ``rec``'s entry: an :class:`Entry` (with ``mode``), or a :class:`Draw`."""
    value, words = _value(rec, _scalar(rec)), _words(rec)
    kinds = ("fixed", "choice") if rec.choices else tuple(DISTRIBUTIONS)
    fields: dict[str, Any] = {
        "distribution": (Literal[kinds], Field(json_schema_extra=allowed(str(list(kinds))))),  # type: ignore[valid-type]
        "value": (value | None, Field(None, json_schema_extra=allowed(words))),
        "values": (
            Annotated[list[value], Field(min_length=1)] | None,
            Field(None, json_schema_extra=allowed(f"a non-empty list, each {words}")),
        ),
    }
    if not rec.choices:
        free = _value(rec, _scalar(rec, bounded=False))
        std = _value(rec, number(ge=0.0))
        fields |= {
            "low": (value | None, Field(None, json_schema_extra=allowed(words))),
            "high": (value | None, Field(None, json_schema_extra=allowed(words))),
            "mean": (
                free | None,
                Field(
                    None, json_schema_extra=allowed(f"{rec.size} finite numbers" if rec.size > 1 else "a finite number")
                ),
            ),
            "std": (
                std | None,
                Field(
                    None,
                    json_schema_extra=allowed(f"{rec.size} numbers >= 0" if rec.size > 1 else "a finite number >= 0"),
                ),
            ),
        }
    if entry:
        modes, why = modes_of(rec)
        rate = schedule_rate(rec.name)
        fields |= {
            # left out (None) only by a schedule without a draw of its own: the nominal value at reset
            "distribution": (
                Optional[Literal[kinds]],
                Field(
                    None,
                    json_schema_extra=allowed(  # type: ignore[valid-type]
                        str(list(kinds))
                    ),
                ),
            ),
            "mode": (Literal[modes], Field("reset", json_schema_extra=allowed(f"{list(modes)}{why}"))),  # type: ignore[valid-type]
            "interval_s": (number(gt=0.0) | None, Field(None, json_schema_extra=allowed("a period > 0 s"))),
            "rate_per_s": (
                Optional[parameter_field(rate, entry=False)],
                Field(
                    None,
                    json_schema_extra=allowed(
                        f"a number [{rate.unit}] (fixed), [low, high] (uniform) or {{distribution: "
                        f"{'|'.join(DISTRIBUTIONS)}, ...}}, drawn once per episode"
                    ),
                ),
            ),
            "delay_s": (number(ge=0.0) | None, Field(None, json_schema_extra=allowed("a time >= 0 s"))),
        }
    model = create_model(f"{rec.name}_entry", __base__=Entry if entry else Draw, **fields)
    model.natural_range = rec.name in NATURAL_RANGE
    return model


def modes_of(rec: Parameter) -> tuple[tuple[str, ...], str]:
    """The modes ``rec``'s entry may take, and why others are not allowed (in words, or '')."""
    if rec.changes == "reset":
        return ("reset",), f" ({rec.name} changes only between episodes)"
    if rec.schedulable:
        return MODES, ""
    what = "a vector" if rec.size > 1 else "a whole number" if rec.integer else "a name" if rec.choices else "fixed"
    return ("reset", "interval"), f" ({rec.name} is {what}: no schedule)"


def parameter_field(rec: Parameter, entry: bool = True) -> Any:
    """The field type of ``rec``'s entry in any form: the full mapping, a value (fixed), a list of
    names (choice) or ``[low, high]`` (uniform; a vector's ``[[low...], [high...]]``); each is
    validated into the full form."""
    full = draw_model(rec, entry)
    value = _value(rec, _scalar(rec))

    def fixed(v: Any) -> Draw:
        return full.model_construct(distribution="fixed", value=v)

    def choice(vs: list) -> Draw:
        return full.model_construct(distribution="choice", values=vs)

    def uniform(pair: list) -> Draw:
        low, high = pair
        return full.model_construct(distribution="uniform", low=low, high=high)

    def form(v: Any) -> str:  # the union's tags are no field names, so error paths leave them out
        if isinstance(v, Mapping):
            return "full-form"
        if isinstance(v, list) and (rec.size == 1 or (v and all(isinstance(x, list) for x in v))):
            return "list-form"
        return "value-form"

    listed = (
        Annotated[list[value], Field(min_length=1), AfterValidator(choice)]
        if rec.choices
        else Annotated[
            list[value], Field(min_length=2, max_length=2), AfterValidator(_low_high), AfterValidator(uniform)
        ]
    )
    return Annotated[
        Union[
            Annotated[value, AfterValidator(fixed), Tag("value-form")],
            Annotated[listed, Tag("list-form")],
            Annotated[full, Tag("full-form")],
        ],
        Discriminator(form),
    ]


def _entry_words(rec: Parameter) -> str:
    if rec.choices:
        return (
            f"a name (fixed), a non-empty list of names (choice) or {{distribution: fixed|choice, value|values}}; "
            f"names: {rec.allowed}"
        )
    pair = "[[low...], [high...]]" if rec.size > 1 else "[low, high]"
    timing = "mode, interval_s, rate_per_s, delay_s" if rec.schedulable else "mode, interval_s"
    return (
        f"{_words(rec)} (fixed), {pair} (uniform) or {{distribution: {'|'.join(DISTRIBUTIONS)}, "
        f"value|low,high|mean,std|values, {timing}}}"
    )


# ---- the whole spec --------------------------------------------------------------------------------
class Schedule(Schema):
    """Pressure within an episode: a rate drawn per episode [kPa/s], after a delay [s]."""

    rate_kpa_per_s: parameter_field(REGISTRY[RATE], entry=False) = Field(
        json_schema_extra=allowed(  # type: ignore[valid-type]
            "a number [kPa/s] (< 0: a leak), [low, high] or {distribution: fixed|uniform|normal|choice, ...}"
        )
    )
    delay_s: number(ge=0.0) = Field(0.0, json_schema_extra=allowed("a time >= 0 s"))


#: One optional field per randomizable parameter, typed from its registry record.
ParameterEntries = create_model(
    "ParameterEntries",
    __base__=Schema,
    **{
        name: (parameter_field(REGISTRY[name]), Field(None, json_schema_extra=allowed(_entry_words(REGISTRY[name]))))
        for name in RANDOMIZABLE
    },
)


def _plain(x: Any) -> Any:
    """Python containers and numpy values as the plain data the schema reads: tuples and arrays as
    lists, numpy scalars as Python numbers (a numpy bool stays a bool: not a number)."""
    if isinstance(x, Mapping):
        return {k: _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, (np.ndarray, np.generic)):
        return x.tolist()
    return x


class SpecInput(ParameterEntries):
    """A spec as a mapping: a preset to start from (``base``), parameter entries over it and the
    pressure schedule (``null``: none, also over a preset's)."""

    base: Literal[PRESETS] = Field(
        "off",
        json_schema_extra=allowed(  # type: ignore[valid-type]
            f"a preset name {list(PRESETS)}: the whole spec, or the mapping's base"
        ),
    )
    pressure_schedule: Schedule | None = Field(
        None, json_schema_extra=allowed("{rate_kpa_per_s: <entry>, delay_s: <s>} or null")
    )
    _order: tuple[str, ...] = PrivateAttr(())

    @model_validator(mode="wrap")
    @classmethod
    def _over_the_preset(cls, data: Any, handler, info: ValidationInfo) -> "SpecInput":
        """The preset's entries first, the mapping's over them (an entry keeps the preset's place:
        terms are drawn in this order); records that order."""
        data = _plain(data)
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
            data = {**preset(data.get("base", "off"), ramp), **data}
        out = handler(data)
        out._order = tuple(k for k in data if k in RANDOMIZABLE)
        return out

    @model_validator(mode="after")
    def _incline_needs_a_ramp(self, info: ValidationInfo) -> "SpecInput":
        entry = self.incline_deg
        if not (info.context or {}).get("ramp", True) and entry is not None and entry.distribution != "fixed":
            raise ValueError(
                f"field 'incline_deg.distribution' = {entry.distribution!r}: this environment has no "
                "ramp, so the incline cannot be randomized; allowed: 'fixed'"
            )
        return self

    def entries(self) -> list[tuple[str, Entry]]:
        """(parameter, entry in full) of every parameter given, in the order given (a preset's first)."""
        return [(name, getattr(self, name)) for name in self._order]


def load_spec(data: Any, ramp: bool, kwarg: str) -> SpecInput:
    """A spec given as data (a preset name or a mapping) as :class:`SpecInput` (``ramp``: the
    environment has one); ``ValueError`` starting with ``<kwarg>:`` and naming the field otherwise."""
    if isinstance(data, str):
        data = {"base": data}
    if not isinstance(data, Mapping):
        raise ValueError(
            f"{kwarg}: value {data!r} ({type(data).__name__}) is not a spec; allowed: None, a preset name "
            f"{list(PRESETS)}, a mapping of parameters to entries or a RandomizationSpec"
        )
    return validate(SpecInput, data, kwarg, context={"ramp": ramp})
