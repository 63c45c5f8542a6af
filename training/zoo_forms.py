"""rl-zoo3's string forms in a hyperparameter file, read as data and never evaluated: ``lin_<x>``
schedules, activation names (``nn.Tanh``, ``tanh``, ...; turned into torch classes only when the
model is built) and ``"dict(...)"`` policy kwargs and ``normalize`` arguments
(:func:`parse_dict_call`)."""

from __future__ import annotations

import ast
from typing import Any

#: Activation names a configuration may give (rl-zoo3 writes ``nn.ReLU``), by torch.nn class.
ACTIVATIONS = {"tanh": "Tanh", "relu": "ReLU", "elu": "ELU", "leaky_relu": "LeakyReLU", "gelu": "GELU", "silu": "SiLU"}


#: A number > 0 written as text: at most 15 digits before the point (after leading zeros), at most
#: 20 zeros after it before a non-zero digit, and an exponent of at most 2 digits, so it reads as a
#: finite number > 0 (never 0, never inf).
POSITIVE_TEXT = r"(?:0*[1-9][0-9]{0,14}(?:\.[0-9]*)?|0*\.0{0,20}[1-9][0-9]*)(?:[eE][-+]?[0-9]{1,2})?"
#: rl-zoo3's linear schedule ``lin_<x>``, x > 0.
LIN_PATTERN = rf"^lin_{POSITIVE_TEXT}$"


def lin_value(text: str) -> float:
    """The initial value of a validated ``lin_<x>`` schedule (:data:`LIN_PATTERN`)."""
    return float(text.removeprefix("lin_"))


def activation_class_name(name: str) -> str:
    """The torch.nn class name of a validated activation (:data:`ACTIVATION_PATTERN`) given as
    ``nn.ReLU``, ``ReLU`` or ``relu``."""
    bare = name.removeprefix("nn.")
    return ACTIVATIONS.get(bare.lower(), bare)


#: An activation: optionally ``nn.``, then a lower-case name of :data:`ACTIVATIONS` in any case, or
#: a class name as torch spells it.
ACTIVATION_PATTERN = (
    r"^(?:nn\.)?(?:(?i:"
    + "|".join(ACTIVATIONS)
    + ")|"
    + "|".join(c for c in ACTIVATIONS.values() if c.lower() not in ACTIVATIONS)
    + ")$"
)


def parse_dict_call(text: str, field_name: str, names: tuple[str, ...] = ()) -> dict[str, Any]:
    """rl-zoo3's ``"dict(key=value, ...)"`` strings (policy kwargs, VecNormalize arguments) read as
    data, never evaluated: the text must be one ``dict(...)`` call (or a ``{...}`` literal) whose
    values are Python literals, nested ``dict(...)`` calls, lists/tuples of these, or one of
    ``names`` (such as ``nn.ReLU``, kept as its text). Anything else raises ValueError naming the
    field (``field_name``, when given)."""
    head = f"{field_name}: " if field_name else ""

    def value(node: ast.AST) -> Any:
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "dict" and not node.args:
            return {kw.arg: value(kw.value) for kw in node.keywords if kw.arg is not None}
        if isinstance(node, ast.Dict):
            return {value(k): value(v) for k, v in zip(node.keys, node.values) if k is not None}
        if isinstance(node, (ast.List, ast.Tuple)):
            items = [value(e) for e in node.elts]
            return items if isinstance(node, ast.List) else tuple(items)
        if isinstance(node, (ast.Attribute, ast.Name)):
            dotted = ast.unparse(node)
            if dotted in names:
                return dotted
            if dotted in ("True", "False", "None"):
                return ast.literal_eval(dotted)
            raise ValueError(f"name {dotted!r} is not allowed; allowed names: {sorted(names) or 'none'}")
        return ast.literal_eval(node)  # numbers, strings, -x; raises ValueError on anything else

    try:
        out = value(ast.parse(text.strip(), mode="eval").body)
    except (SyntaxError, ValueError, TypeError) as err:
        raise ValueError(
            f"{head}cannot read {text!r} as data: {err}; allowed: dict(key=value, ...) with literal values"
        ) from None
    if not isinstance(out, dict):
        raise ValueError(f"{head}{text!r} must be a dict(...) of keyword arguments")
    return out


def dict_text(names: tuple[str, ...] = ()):
    """A before-validator reading rl-zoo3's ``"dict(...)"`` text as a mapping."""

    def read(value: Any) -> Any:
        return parse_dict_call(value, "", names) if isinstance(value, str) else value

    return read


ACTIVATION_NAMES = tuple(f"nn.{n}" for n in ACTIVATIONS.values())
