"""One randomization term: what is drawn, when, and from which distribution, as a typed schema.

A :class:`Distribution` is a draw given in full (``distribution``: ``fixed`` | ``uniform`` |
``normal`` | ``choice`` and the fields it takes) and samples itself; a :class:`Term` is a
parameter's distribution with its timing (``mode``: ``reset`` | ``interval`` | ``schedule``). Each
randomizable parameter of :mod:`sphere_env.params` has its own subclasses (:func:`term_model`),
whose fields are typed from the parameter's record (bounds, whole numbers, vector size, categorical
names); :func:`parameter_field` also reads the short forms (a number: fixed; ``[low, high]``:
uniform; a list of names: choice) into a full term. A value of the wrong type (a string or a bool is
never a number), outside its parameter's bounds, or a distribution without the fields it needs is
refused as ``field '<path>' = <value>: <problem>; allowed: <what>``. Vectors are held as tuples.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Annotated, Any, ClassVar, Literal, Mapping, Optional, Union

import numpy as np
from pydantic import (
    AfterValidator,
    BeforeValidator,
    Discriminator,
    Field,
    Tag,
    create_model,
    model_validator,
)

from sphere_env.parameter import Parameter
from sphere_env.params import PARAMETERS as REGISTRY
from sphere_env.params import schedule_rate
from sphere_env.schemas import Schema, _integral, _ordered, allowed, number

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
    """``scalar``, or a list of ``rec.size`` of them for a vector parameter (held as a tuple)."""
    if rec.size == 1:
        return scalar
    return Annotated[list[scalar], Field(min_length=rec.size, max_length=rec.size), AfterValidator(tuple)]


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
        BeforeValidator(plain),
        Field(json_schema_extra=allowed(f"a fixed value: {_words(rec)}")),
    ]


#: The uniform distribution's bounds: low <= high (each component of a vector).
_low_high = _ordered(strict=False)


# ---- a distribution given in full ------------------------------------------------------------------
class Distribution(Schema):
    """One distribution given in full: ``distribution`` (its :attr:`kind`; when left out: the one
    whose fields are given, else ``fixed``) and the fields it takes (:data:`DISTRIBUTIONS`), nothing
    else. ``uniform`` draws within [``low``, ``high``] (both left out: the parameter's natural
    range, :data:`NATURAL_RANGE`, filled in by ``RandomizationSpec.resolved``); ``normal`` draws
    around ``mean`` with ``std`` (the caller clips to the parameter's bounds); ``choice`` draws one
    of ``values``. Scalars, or tuples for vector parameters (drawn per component). Each
    parameter's subclass (:func:`term_model`) types the fields from the parameter's record."""

    #: the parameter drawn (each parameter's subclass sets it)
    parameter: ClassVar[str] = ""
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
    def _fields_of_the_distribution(self) -> "Distribution":
        kind = self.kind
        if kind is None:  # a term's schedule without a draw (checked by the term)
            return self
        takes = DISTRIBUTIONS[kind]
        others = {k for fields in DISTRIBUTIONS.values() for k in fields} - set(takes)
        for key in sorted(others):
            if getattr(self, key, None) is not None:
                keys = {info.alias or name for name, info in type(self).model_fields.items()}
                raise ValueError(
                    f"field {key!r} is not used by distribution {kind!r}; allowed: {sorted(keys - others)}"
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

    def sample(self, rng: np.random.Generator, size: int) -> Any:
        """One value: a number, a name, or a tuple of ``size`` numbers for a vector parameter."""
        if self.kind == "fixed":
            return self.value
        if self.kind == "choice":
            return self.values[int(rng.integers(len(self.values)))]
        if self.kind == "uniform":
            x = rng.uniform(self.low, self.high, size=size)
        else:  # normal
            x = rng.normal(self.mean, self.std, size=size)
        return float(x[0]) if size == 1 else tuple(float(v) for v in x)

    def as_data(self) -> dict[str, Any]:
        """The mapping this distribution is written as: its kind and the fields it sets."""
        fields = {key: getattr(self, key, None) for keys in DISTRIBUTIONS.values() for key in keys}
        return {"distribution": self.kind, **{k: plain(v) for k, v in fields.items() if v is not None}}


class Term(Distribution):
    """A parameter's term given in full: a :class:`Distribution`, and when it is drawn: at every
    ``reset``, every ``interval_s`` seconds of sim time (``interval``), or at reset with a rate of
    change ``rate_per_s`` (itself a distribution, drawn once per episode) that moves the value after
    ``delay_s`` (``schedule``; without a draw of its own, :attr:`distribution` None, the schedule
    starts from the nominal value). The event manager reads these terms
    (:class:`~sphere_env.tasks.events.EventManager`)."""

    @property
    def distribution(self) -> "Term | None":
        """The term's draw at reset: the term itself, or None when a schedule draws nothing."""
        return None if self.kind is None else self

    @model_validator(mode="after")
    def _mode_fields(self) -> "Term":
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
                if isinstance(value, Distribution):  # as given: a number, or the distribution's mapping
                    value = value.value if value.kind == "fixed" else value.as_data()
                raise ValueError(
                    f"field {key!r} = {value!r} is only for mode {owner!r}; allowed: leave it out for mode {mode!r}"
                )
        if self.kind is None and mode != "schedule":
            raise ValueError(
                f"field 'distribution' = None: only mode 'schedule' may leave out the draw; allowed: "
                f"{list(DISTRIBUTIONS)}"
            )
        if mode == "schedule" and self.delay_s is None:
            object.__setattr__(self, "delay_s", 0.0)
        return self

    def as_data(self) -> dict[str, Any]:
        """The mapping this term is written as: its draw (if any), mode and timing."""
        draw = {} if self.kind is None else super().as_data()
        timing = {key: getattr(self, key) for key in ("interval_s", "delay_s") if getattr(self, key) is not None}
        if self.rate_per_s is not None:
            timing["rate_per_s"] = self.rate_per_s.as_data()
        return {**draw, "mode": self.mode, **timing}


@lru_cache(maxsize=None)
def term_model(rec: Parameter, entry: bool = True) -> type[Distribution]:
    """The full form of ``rec``'s term: a :class:`Term` (with ``mode``), or a :class:`Distribution`.
    One class per parameter and form, a name of this module (so that a spec pickles)."""
    value, words = _value(rec, _scalar(rec)), _words(rec)
    kinds = ("fixed", "choice") if rec.choices else tuple(DISTRIBUTIONS)
    fields: dict[str, Any] = {
        "kind": (
            Literal[kinds],  # type: ignore[valid-type]
            Field(alias="distribution", json_schema_extra=allowed(str(list(kinds)))),
        ),
        "value": (value | None, Field(None, json_schema_extra=allowed(words))),
        "values": (
            Annotated[list[value], Field(min_length=1), AfterValidator(tuple)] | None,
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
            "kind": (
                Optional[Literal[kinds]],  # type: ignore[valid-type]
                Field(None, alias="distribution", json_schema_extra=allowed(str(list(kinds)))),
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
    name = f"{rec.name}_{'term' if entry else 'distribution'}"
    model = create_model(name, __base__=Term if entry else Distribution, __module__=__name__, **fields)
    model.parameter = rec.name
    model.natural_range = rec.name in NATURAL_RANGE
    globals()[name] = model
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
    full = term_model(rec, entry)
    value = _value(rec, _scalar(rec))

    def fixed(v: Any) -> Distribution:
        return full.model_construct(kind="fixed", value=v)

    def choice(vs: list) -> Distribution:
        return full.model_construct(kind="choice", values=tuple(vs))

    def uniform(pair: list) -> Distribution:
        low, high = pair
        return full.model_construct(kind="uniform", low=low, high=high)

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


def term_words(rec: Parameter) -> str:
    """Every form a term of ``rec`` may take, in words."""
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


# ---- the pressure's schedule ----------------------------------------------------------------------
class PressureSchedule(Schema):
    """Pressure within an episode: p(t) = clip(p₀ + rate · max(t − delay_s, 0)) to the calibration
    range, p₀ the episode's (drawn) pressure; the rate [kPa/s] (< 0: a leak) is drawn once per
    episode, the delay [s] is fixed."""

    rate_kpa_per_s: parameter_field(REGISTRY[RATE], entry=False) = Field(
        json_schema_extra=allowed(  # type: ignore[valid-type]
            "a number [kPa/s] (< 0: a leak), [low, high] or {distribution: fixed|uniform|normal|choice, ...}"
        )
    )
    delay_s: number(ge=0.0) = Field(0.0, json_schema_extra=allowed("a time >= 0 s"))

    def as_data(self) -> dict[str, Any]:
        """The mapping this schedule is written as."""
        return {"rate_kpa_per_s": self.rate_kpa_per_s.as_data(), "delay_s": self.delay_s}


def plain(x: Any) -> Any:
    """Python containers and numpy values as the plain data the schema reads: tuples and arrays as
    lists, numpy scalars as Python numbers (a numpy bool stays a bool: not a number)."""
    if isinstance(x, Mapping):
        return {k: plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [plain(v) for v in x]
    if isinstance(x, (np.ndarray, np.generic)):
        return x.tolist()
    return x
