"""Typed input schemas: pydantic models that refuse unknown keys and wrong types by name.

Every schema derives from :class:`Schema` (``extra="forbid"``, strict types: a string is never a
number, a number never a string; an int is a float). :func:`validate` loads a mapping into a
schema and turns pydantic's errors into one line that names the field (its path), the value and
what is allowed, raised as the caller's error type. Loading is the only place an input is checked:
what a schema returns is valid.

Each field may state what it allows in words (``Field(json_schema_extra={"allowed": ...})``); the
error message quotes it, else it says what pydantic expected.
"""

from __future__ import annotations

import math
import reprlib
from argparse import ArgumentTypeError
from itertools import islice
from pathlib import Path
from typing import Annotated, Any, Callable, ClassVar, Mapping, TypeVar, get_args

import numpy as np
from pydantic import AfterValidator, BaseModel, BeforeValidator, ConfigDict, Field, TypeAdapter, ValidationError
from pydantic.fields import FieldInfo

S = TypeVar("S", bound="Schema")
B = TypeVar("B", bound="Built")
FIELD = "field '"  # how every message names a field


#: The longest echo of an input value in a message [characters].
SHOWN_CHARS = 200


class _InOrder(reprlib.Repr):
    """reprlib's cut ``repr`` with a mapping's items in their own order (reprlib sorts them)."""

    def repr_dict(self, x, level):
        if not x:
            return "{}"
        if level <= 0:
            return "{...}"
        items = [f"{self.repr1(k, level - 1)}: {self.repr1(v, level - 1)}" for k, v in islice(x.items(), self.maxdict)]
        return "{" + ", ".join(items + (["..."] if len(x) > self.maxdict else [])) + "}"


def shown(value: Any, limit: int = SHOWN_CHARS) -> str:
    """``repr(value)`` cut for a message: a few items per level, a few levels, at most ``limit``
    characters (an input can be megabytes, or a few bytes of YAML aliases that expand to billions
    of items)."""
    r = _InOrder()
    r.maxlevel, r.maxdict, r.maxlist, r.maxtuple, r.maxset, r.maxfrozenset = 3, 6, 6, 6, 6, 6
    r.maxstring, r.maxother, r.maxlong = limit, limit, 60
    text = r.repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


class Schema(BaseModel):
    """Base of every input schema: unknown keys and wrong types refused, values immutable."""

    model_config = ConfigDict(extra="forbid", strict=True, frozen=True)


class Built(Schema):
    """A schema that code builds by calling it with keywords, such as a configuration object
    (``TwinConfig(shell_model="point")``): a bad value raises the ``ValueError`` that
    :func:`validate` raises, ``<where>: field '<root>.<path>' = <value>: <problem>; allowed: ...``
    (:attr:`where`, :attr:`root`: the class's own)."""

    #: what the message names as the input (``where`` of :func:`validate`)
    where: ClassVar[str] = ""
    #: the mapping's own name (``root`` of :func:`validate`)
    root: ClassVar[str] = ""

    def __init__(self, **data: Any) -> None:
        try:
            super().__init__(**data)
        except ValidationError as err:
            head = f"{self.where}: " if self.where else ""
            raise ValueError(head + first_problem(type(self), err, self.root)) from None

    # Marked as pydantic's own __init__, so that validating a Built nested in another schema (an
    # InitialState in the reset options) stays pydantic's, and its errors name the outer path.
    __init__.__pydantic_base_init__ = True  # type: ignore[attr-defined]

    def fields(self) -> dict[str, Any]:
        """The fields by name, as they hold their values (nested schemas stay objects)."""
        return {name: getattr(self, name) for name in type(self).model_fields}

    def replace(self: B, **changes: Any) -> B:
        """A copy with ``changes``, validated as a new object is."""
        return type(self)(**{**self.fields(), **changes})


def allowed(text: str) -> dict[str, Any]:
    """``json_schema_extra`` stating a field's allowed values in words (quoted by error messages)."""
    return {"allowed": text}


def _integral(value: Any) -> Any:
    """A float with an integer value as that int (YAML's ``!!float 2e6`` for a count); anything else
    unchanged, for the strict int check to judge."""
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return value


def count(low: int = 1, high: int | None = None) -> Any:
    """An integer within [low, high] (``2e6`` written as a float is one; a bool is not)."""
    words = f"an integer >= {low}" if high is None else f"an integer within [{low}, {high}]"
    return Annotated[int, BeforeValidator(_integral), Field(ge=low, le=high, json_schema_extra=allowed(words))]


def _real(value: Any) -> Any:
    """A numpy number as the Python number it holds (a numpy bool is refused: a bool is not a
    number); anything else unchanged, for the strict float check to judge."""
    if isinstance(value, np.bool_):
        raise ValueError("a bool is not a number")
    if isinstance(value, (np.generic, np.ndarray)) and np.ndim(value) == 0 and value.dtype.kind in "iuf":
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):  # before any bound: NaN compares false
        raise ValueError("not a finite number")
    return value


def _as_tuple(value: Any) -> Any:
    """A list or a 1-d numpy array as a tuple of its items (YAML and numpy have no tuples); anything
    else unchanged, for the tuple check to judge."""
    if isinstance(value, np.ndarray) and value.ndim == 1:
        return tuple(value.tolist())
    return tuple(value) if isinstance(value, list) else value


def fixed_tuple(item: Any, size: int, words: str) -> Any:
    """A tuple of ``size`` ``item`` values (a list or numpy array is one), its allowed values in words."""
    return Annotated[tuple[(item,) * size], BeforeValidator(_as_tuple), Field(json_schema_extra=allowed(words))]


#: A finite real number (an int or a numpy number is one; a bool or a string is not).
Finite = Annotated[
    float, BeforeValidator(_real), Field(allow_inf_nan=False, json_schema_extra=allowed("a finite number"))
]


def number(
    *,
    gt: float | None = None,
    ge: float | None = None,
    lt: float | None = None,
    le: float | None = None,
    words: str | None = None,
) -> Any:
    """A finite real number within the given bounds, its allowed range stated in words (``words``,
    else the bounds)."""
    parts = [f"{op} {v:g}" for op, v in ((">", gt), (">=", ge), ("<", lt), ("<=", le)) if v is not None]
    words = words or "a finite number" + (" " + " and ".join(parts) if parts else "")
    return Annotated[
        float,
        BeforeValidator(_real),
        Field(gt=gt, ge=ge, lt=lt, le=le, allow_inf_nan=False, json_schema_extra=allowed(words)),
    ]


def _ordered(strict: bool) -> Callable[[tuple[Any, Any]], tuple[Any, Any]]:
    """An after-validator of a pair (low, high) of numbers or of equal-length vectors (each
    component): low <= high (``strict``: low < high)."""

    def check(pair: tuple[Any, Any]) -> tuple[Any, Any]:
        low, high = np.asarray(pair[0], dtype=float), np.asarray(pair[1], dtype=float)
        if np.any(low > high) or (strict and np.any(low == high)):
            low_given, high_given = (list(v) if isinstance(v, tuple) else v for v in pair)  # as written
            raise ValueError(f"low {shown(low_given)} is {'not below' if strict else 'above'} high {shown(high_given)}")
        return pair

    return check


def ordered_pair(
    low: float | None, high: float | None, unit: str, strict: bool = False, words: str | None = None
) -> Any:
    """A pair (low, high) of finite numbers with ``low`` <= low <= high <= ``high`` [``unit``]
    (``low``/``high`` None: unbounded on that side; ``strict``: low < high), its allowed values in
    ``words`` (default: the bounds)."""
    if words is None:
        left = "" if low is None else f"{low:g} <= "
        right = "" if high is None else f" <= {high:g}"
        words = f"a pair (low, high) with {left}low {'<' if strict else '<='} high{right} {unit}"
    item = number(ge=low, le=high)
    return Annotated[
        tuple[item, item],
        AfterValidator(_ordered(strict)),
        BeforeValidator(_as_tuple),
        Field(json_schema_extra=allowed(words)),
    ]


def validate(
    schema: type[S],
    data: Any,
    where: str = "",
    error: type[Exception] = ValueError,
    root: str = "",
    context: Mapping[str, Any] | None = None,
) -> S:
    """``data`` as ``schema``, or ``error`` with one line naming the first problem (an unknown key
    before any other): ``<where>: field '<root>.<dotted.path>' = <value>: <problem>; allowed:
    <allowed>`` (``where``: the input, such as a file; ``root``: the mapping's own name;
    ``context``: what validators that depend on the caller read, as pydantic's validation context)."""
    head = f"{where}: " if where else ""
    if not isinstance(data, Mapping):
        name = f"field {root!r}" if root else "the input"  # its type only: never echo a file's contents
        raise error(f"{head}{name} is a {type(data).__name__}, not a mapping; allowed keys: {sorted(keys(schema))}")
    try:
        return schema.model_validate(dict(data), context=context)
    except ValidationError as err:
        raise error(f"{head}{first_problem(schema, err, root)}") from None


def first_problem(schema: type[BaseModel], err: ValidationError, root: str = "") -> str:
    """The first problem of ``err`` (an unknown key before any other) in the words of
    :func:`describe`."""
    errors = [{**e, "loc": field_loc(schema, e["loc"], e["type"] == "extra_forbidden")} for e in err.errors()]
    # an unknown key first: a typo also makes the key it was meant to be "missing"
    first = next((e for e in errors if e["type"] == "extra_forbidden"), errors[0])
    # of a union's branches failing at one field, the one with a validator's own words
    first = next((e for e in errors if e["loc"] == first["loc"] and e["type"] == "value_error"), first)
    return describe(schema, first, root)


def keys(model: type[BaseModel]) -> dict[str, FieldInfo]:
    """A schema's fields by the key an input gives them: the field's alias, else its name."""
    return {info.alias or name: info for name, info in model.model_fields.items()}


def field_loc(schema: type[BaseModel], loc: tuple, unknown_key: bool = False) -> tuple:
    """A pydantic error location without its union branch tags (``constrained-float``,
    ``function-after[...]``, ``str``, a tagged union's tags): only field names, list indices and
    mapping keys stay, and the last part of an ``unknown_key`` error (the key refused)."""
    out: list = []
    model: type[BaseModel] | None = schema
    for i, p in enumerate(loc):
        last = i == len(loc) - 1
        if isinstance(p, int):
            out.append(p)
        elif model is not None and p in keys(model):
            out.append(p)
            model = _model_in(keys(model)[p].annotation)
        elif model is None and not _is_tag(p):
            out.append(p)  # a key of a free mapping
        elif last and unknown_key:
            out.append(p)  # an unknown key of a model
    return tuple(out)


def _is_tag(part: str) -> bool:
    return not part.isidentifier() or part in ("str", "int", "float", "bool", "list", "dict", "tuple", "none")


def describe(schema: type[BaseModel], e: Mapping[str, Any], root: str = "") -> str:
    """One pydantic error as ``field '<root>.<dotted.path[i]>' = value: problem; allowed: ...``, the
    path counted from the schema's top level."""
    loc = tuple(e["loc"])
    model, field = _owner(schema, loc)
    where = _path(((root,) if root else ()) + loc)
    if e["type"] == "missing" and loc and isinstance(loc[-1], int):  # a sequence too short
        where = _path(((root,) if root else ()) + loc[:-1])
        return f"field {where!r} = {shown(e.get('input'))}: too few items" + _allowed(field)
    if e["type"] == "missing":
        return f"field {where!r} is missing"
    if e["type"] == "extra_forbidden":
        fields = sorted(keys(model)) if model is not None else []
        return f"unknown field {where!r}; allowed: {fields}"
    msg = e["msg"].removeprefix("Value error, ").removeprefix("Assertion failed, ")
    if e["type"] == "value_error" and msg.startswith("field '"):
        # a validator of a section, naming its fields relative to the section
        return f"field '{where}.{msg.removeprefix(FIELD)}" if where else msg
    # a nested schema's message may already say what is allowed
    value = e.get("input")
    value = str(value) if isinstance(value, Path) else value  # a path as its text, as the user typed it
    msg = msg if len(msg) <= 4 * SHOWN_CHARS else msg[: 4 * SHOWN_CHARS - 3] + "..."
    return f"field {where!r} = {shown(value)}: {msg}" + ("" if "allowed" in msg else _allowed(field))


def _allowed(field: FieldInfo | None) -> str:
    """``; allowed: <words>`` of a field: its own, else those of an optional type's branch (``... or
    None``); empty without words."""
    if field is None:
        return ""
    words = _words(field)
    if words is None:
        args = get_args(field.annotation)
        branch = next((w for w in map(_words, args) if w is not None), None)
        words = None if branch is None else branch + (" or None" if type(None) in args else "")
    return f"; allowed: {words}" if words else ""


def _words(part: Any) -> str | None:
    """The allowed words of a FieldInfo or of an ``Annotated`` type's FieldInfo metadata."""
    if isinstance(part, FieldInfo):
        extra = part.json_schema_extra
        return extra.get("allowed") if isinstance(extra, dict) else None
    return next((w for w in map(_words, getattr(part, "__metadata__", ())) if w is not None), None)


def _path(loc: tuple) -> str:
    out = ""
    for p in loc:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out


def _owner(schema: type[BaseModel], loc: tuple):
    """(the model that holds the last named field of ``loc``, that field's FieldInfo or None)."""
    model, field = schema, None
    names = [i for i, p in enumerate(loc) if isinstance(p, str)]
    for i in names:
        p = loc[i]
        if model is None or p not in keys(model):
            return model, None
        field = keys(model)[p]
        if i != names[-1]:
            model = _model_in(field.annotation)
    return model, field


def _model_in(ann: Any) -> type[BaseModel] | None:
    if isinstance(ann, type) and issubclass(ann, BaseModel):
        return ann
    for a in get_args(ann) or ():
        m = _model_in(a)
        if m is not None:
            return m
    return None


def _type_words(annotation: Any) -> str:
    """The allowed words of a type: an ``Annotated`` type's own, else those of a union's branch
    (``... or None``); "" without words."""
    words = _words(annotation)
    if words is None:
        args = get_args(annotation)
        words = next((w for w in map(_words, args) if w is not None), None)
        if words is not None and type(None) in args:
            words += " or None"
    return words or ""


def checker(annotation: Any) -> Callable[..., Any]:
    """A check of one value that no schema field holds (a function's argument, a bound known only at
    run time such as ``number(ge=lo, le=hi)``): ``check(value, name)`` returns ``value`` validated as
    ``annotation`` (strict: a string is never a number, a bool never an int) or raises ``error``
    (default ValueError) with one line ``<name> = <value>: <problem>; allowed: <words>``, the words
    of the annotation (:func:`allowed`); ``name`` says where the value was given, as
    :func:`validate` does (``field 'seed'``, ``options: field 'pressure_kpa'``, ``--tol``)."""
    adapter = TypeAdapter(annotation, config=ConfigDict(strict=True))
    words = _type_words(annotation)

    def check(value: Any, name: str, error: type[Exception] = ValueError) -> Any:
        try:
            return adapter.validate_python(value)
        except ValidationError as err:
            problem = err.errors()[0]["msg"].removeprefix("Value error, ")
            raise error(f"{name} = {shown(value)}: {problem}" + (f"; allowed: {words}" if words else "")) from None

    return check


def cli_type(annotation: Any, parse: Callable[[str], Any] = float, name: str = "value") -> Callable[[str], Any]:
    """An argparse ``type=`` that reads a command-line word with ``parse`` (``float``, ``int``) and
    checks it against ``annotation`` (a bounded type such as :func:`number` or :func:`count`): a bad
    word ends the command with argparse's one-line error naming the flag, the value and what is
    allowed."""
    adapter = TypeAdapter(annotation)
    words = next(
        (
            m.json_schema_extra["allowed"]
            for m in get_args(annotation)[1:]
            if isinstance(m, FieldInfo) and isinstance(m.json_schema_extra, dict)
        ),
        "",
    )

    def read(text: str) -> Any:
        try:
            value = parse(text)
        except ValueError:
            raise ArgumentTypeError(
                f"{shown(text)} is not {'an integer' if parse is int else 'a number'}; allowed: {words}"
            ) from None
        try:
            return adapter.validate_python(value)
        except ValidationError as err:
            problem = err.errors()[0]["msg"].removeprefix("Value error, ")
            raise ArgumentTypeError(f"{shown(text)}: {problem}; allowed: {words}") from None

    read.__name__ = name  # argparse names the type in some messages
    return read
