"""Blocks listing the randomizable parameters, rendered from the parameter registry
(``sphere_env/params.py``) rather than from results files: a parameter added to the registry shows
in ``docs/envs.md`` and the README once the pages are regenerated (``make docs``), and the docs
check fails until they are."""

from __future__ import annotations

from sphere_env.evaluation.experiments.docs.base import Results, renders, table
from sphere_env.parameter import Parameter
from sphere_env.params import PARAMETERS, RANDOMIZABLE
from sphere_env.tasks.terms import modes_of


def _nominal(rec: Parameter) -> str:
    if rec.bounds_from is not None:
        return f"the {rec.bounds_from}'s"
    if rec.nominal is None:
        return "the env's kwarg"
    return str(rec.nominal) if isinstance(rec.nominal, (tuple, str)) else f"{rec.nominal:g}"


def _bounds(rec: Parameter) -> str:
    if rec.bounds_from is not None:
        return f"the {rec.bounds_from}'s range"
    return rec.allowed + (f", {rec.size} components" if rec.size > 1 else "")


@renders("randomizable_parameters")
def randomizable_parameters(_: Results) -> str:
    """Every randomizable parameter: unit, nominal value, bounds, modes, who applies it and what it is."""
    rows = []
    for name in RANDOMIZABLE:
        rec = PARAMETERS[name]
        rows.append(
            [
                f"`{name}`",
                rec.unit,
                _nominal(rec),
                _bounds(rec),
                ", ".join(modes_of(rec)[0]),
                rec.applied_by or "a twin per value",
                rec.doc.replace("|", "\\|"),
            ]
        )
    return table(["parameter", "unit", "nominal", "bounds", "modes", "applied by", "what"], rows)


@renders("randomizable_names")
def randomizable_names(_: Results) -> str:
    """The randomizable parameters' names, inline."""
    return ", ".join(f"`{name}`" for name in RANDOMIZABLE)
