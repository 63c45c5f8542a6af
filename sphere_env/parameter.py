"""One record of the parameter registry (:data:`sphere_env.params.PARAMETERS`): a parameter's name,
unit, nominal value, bounds and when it may change, and the checks and clipping of its values.

Pure Python (no Drake).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Any, Literal

from pydantic import TypeAdapter, ValidationError

from sphere_env.schemas import count, fixed_tuple, number


@dataclass(frozen=True)
class Parameter:
    """One parameter: name (with unit), unit, nominal value, bounds and when it may change.

    ``low``/``high`` are ``None`` where the bound does not exist, or where it comes from a context
    (``bounds_from``) until a :class:`~sphere_env.params.ParameterSpace` fills it in; ``low_open``/``high_open``
    exclude the bound. ``size`` > 1 for vector parameters (each component within the bounds).
    """

    name: str
    unit: str
    nominal: Any
    low: float | None
    high: float | None
    changes: str
    doc: str
    size: int = 1
    low_open: bool = False
    high_open: bool = False
    integer: bool = False
    #: a categorical parameter's values (then ``low``/``high`` are None and values are names)
    choices: tuple[str, ...] = ()
    #: who applies a value within an episode: the twin's context (``twin``), the environment's
    #: sensing and actuation (``env``), or neither (set when a twin is built or chosen)
    applied_by: Literal["twin", "env"] | None = None
    #: whether a randomization spec or an event may set it
    randomizable: bool = False
    #: where nominal value and bounds come from when they are not in the record: ``calibration``
    #: (the shell calibration's nominal pressure and range, filled in by a :class:`~sphere_env.params.ParameterSpace`)
    bounds_from: Literal["calibration"] | None = None
    #: the bounds in words when a :class:`~sphere_env.params.ParameterSpace` filled them in (they say where from)
    bounds_text: str | None = None
    #: what a value near a bound costs (compute, memory), quoted after the bounds
    cost: str = ""

    @property
    def schedulable(self) -> bool:
        """Whether a randomization spec may give it mode ``schedule`` (a rate of change within the
        episode): a randomizable number, neither vector, whole number nor name, that may change at any
        control step."""
        return self.randomizable and self.changes == "step" and self.size == 1 and not self.integer and not self.choices

    @property
    def resolved(self) -> bool:
        """Whether the record's bounds are known (a ``bounds_from`` record: once a space filled them in)."""
        return self.bounds_from is None or self.bounds_text is not None

    def _require_bounds(self) -> None:
        if not self.resolved:
            raise LookupError(
                f"{self.name}: its bounds come from the {self.bounds_from}; check and clip it "
                "through a ParameterSpace (e.g. ShellCalibration.parameter_space())"
            )

    @property
    def allowed(self) -> str:
        """The bounds as text, e.g. ``(0, 0.05] s``, or a categorical parameter's names."""
        if self.bounds_text is not None:
            return self.bounds_text
        if self.choices:
            return str(list(self.choices))
        lo = "-inf" if self.low is None else f"{self.low:g}"
        hi = "inf" if self.high is None else f"{self.high:g}"
        unit = "" if self.unit == "-" else f" {self.unit}"
        cost = f" ({self.cost})" if self.cost else ""
        return f"{'(' if self.low_open or self.low is None else '['}{lo}, {hi}{')' if self.high_open or self.high is None else ']'}{unit}{cost}"

    def contains(self, value: Any) -> bool:
        if self.choices:
            return isinstance(value, str) and value in self.choices
        if isinstance(value, str):
            return False
        lo, hi = self.low, self.high
        if lo is not None and (value < lo or (self.low_open and value == lo)):
            return False
        if hi is not None and (value > hi or (self.high_open and value == hi)):
            return False
        return True

    @cached_property
    def value_type(self) -> Any:
        """The type of one value, as a schema field's annotation: a name of ``choices``, an integer, a
        finite number or ``size`` of them, within the bounds (a bool or a string is never a number);
        error messages quote :attr:`allowed`."""
        if self.choices:
            return Literal[self.choices]
        bounds = {("gt" if self.low_open else "ge"): self.low, ("lt" if self.high_open else "le"): self.high}
        bounds = {k: v for k, v in bounds.items() if v is not None}
        if self.integer:
            item = count(int(bounds.get("ge", 0)), None if "le" not in bounds else int(bounds["le"]))
        else:
            item = number(**bounds, words=self.allowed)
        return item if self.size == 1 else fixed_tuple(item, self.size, self.allowed)

    @cached_property
    def _type(self) -> TypeAdapter:
        """:attr:`value_type`, strict."""
        return TypeAdapter(self.value_type, config={"strict": True})

    def check(self, value: Any, field: str | None = None):
        """``value`` as a float (an int for an integer parameter, a tuple of ``size`` floats for a
        vector one, a name for a categorical one) within the bounds; otherwise a ``ValueError`` in
        the schemas' dialect, ``<field> = <value>: <problem>; allowed: <bounds>`` (``field``: where
        the value was given, default ``field '<name>'``)."""
        self._require_bounds()
        try:
            return self._type.validate_python(value)
        except ValidationError as err:
            problem = err.errors()[0]["msg"].removeprefix("Value error, ")
            if self.size > 1:
                problem, allowed = "not a valid vector", f"{self.size} finite numbers within {self.allowed}"
            else:
                allowed = self.allowed
            raise ValueError(f"{field or f'field {self.name!r}'} = {value!r}: {problem}; allowed: {allowed}") from None

    def clip(self, value: float) -> float:
        """Clip into the bounds (an open bound clips to the nearest allowed float)."""
        self._require_bounds()
        lo, hi = self.low, self.high
        if self.integer:
            value = round(value)
        if lo is not None and value <= lo:
            return math.nextafter(lo, math.inf) if self.low_open else lo
        if hi is not None and value >= hi:
            return math.nextafter(hi, -math.inf) if self.high_open else hi
        return value
