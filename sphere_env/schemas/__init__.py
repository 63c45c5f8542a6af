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

from typing import Any, Mapping, TypeVar, get_args

from pydantic import BaseModel, ConfigDict, ValidationError

S = TypeVar("S", bound="Schema")


class Schema(BaseModel):
    """Base of every input schema: unknown keys and wrong types refused, values immutable."""

    model_config = ConfigDict(extra="forbid", strict=True, frozen=True)


def allowed(text: str) -> dict[str, Any]:
    """``json_schema_extra`` stating a field's allowed values in words (quoted by error messages)."""
    return {"allowed": text}


def validate(schema: type[S], data: Any, where: str, error: type[Exception] = ValueError) -> S:
    """``data`` as ``schema``, or ``error`` with one line per the first problem:
    ``<where>: <path>: field '<name>' = <value>: <problem>; allowed: <allowed>``."""
    if not isinstance(data, Mapping):
        raise error(f"{where}: must be a mapping of {sorted(schema.model_fields)}, got {type(data).__name__}")
    try:
        return schema.model_validate(dict(data))
    except ValidationError as err:
        raise error(f"{where}: {describe(schema, err.errors()[0])}") from None


def describe(schema: type[BaseModel], e: Mapping[str, Any]) -> str:
    """One pydantic error as ``path: field 'name' = value: problem; allowed: ...``."""
    loc = tuple(p for p in e["loc"] if not (isinstance(p, str) and "[" in p))  # drop union branch tags
    model, field = _owner(schema, loc)
    name = loc[-1] if loc else ""
    path = _path(loc[:-1])
    prefix = f"{path}: " if path else ""
    if e["type"] == "missing":
        return f"{prefix}field {name!r} is missing"
    if e["type"] == "extra_forbidden":
        fields = sorted(model.model_fields) if model is not None else []
        return f"{prefix}unknown field {name!r}; allowed: {fields}"
    msg = e["msg"].removeprefix("Value error, ").removeprefix("Assertion failed, ")
    value = e.get("input")
    if isinstance(name, int):  # an item of a list field: name the field and the item
        prefix, name = (f"{_path(loc[:-2])}: " if len(loc) > 2 else ""), f"{loc[-2]}[{name}]"
    text = f"{prefix}field {name!r} = {value!r}: {msg}"
    words = ((field.json_schema_extra or {}).get("allowed") if field is not None
             and isinstance(field.json_schema_extra, dict) else None)
    return text + (f"; allowed: {words}" if words else "")


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
        if model is None or p not in model.model_fields:
            return model, None
        field = model.model_fields[p]
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
