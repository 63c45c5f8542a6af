"""The evaluation sweep's typed schema: what ``evaluate`` runs, checked before any worker starts.

:class:`SweepFields` holds every field of :class:`sphere_env.evaluation.evaluate.SweepSpec` with its
type and range; checks that need an env, a controller or the calibration (pressures inside the
calibrated range, a controller's first action) stay in ``SweepSpec.validate``.
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field, field_validator

from sphere_env.params import SHELL_MODELS
from sphere_env.schemas import Finite, Schema, allowed, count

#: Env kwargs the sweep sets per cell (refused in ``env_kwargs``) and the option that sets each.
GRID_KWARGS = {"shell_model": "--shell-models", "friction_model": "--friction", "randomization": "off",
               "record_replay": "--replay"}


class SweepFields(Schema):
    """A grid to evaluate (see ``SweepSpec``)."""

    controllers: list[str] = Field(min_length=1, json_schema_extra=allowed("at least one controller"))
    env_id: str
    pressures_kpa: list[Finite] = Field(min_length=1, json_schema_extra=allowed("at least one pressure [kPa]"))
    shell_models: list[Literal[SHELL_MODELS]] = Field(  # type: ignore[valid-type]
        min_length=1, json_schema_extra=allowed(f"a non-empty list of {list(SHELL_MODELS)}"))
    frictions: list[str] = Field(min_length=1, json_schema_extra=allowed("at least one friction law"))
    seeds: list[count(0)] = Field(min_length=1, json_schema_extra=allowed("at least one integer >= 0"))
    env_kwargs: dict[str, Any] = Field(json_schema_extra=allowed("a mapping of env kwargs"))
    allow_env_mismatch: bool = False

    @field_validator("env_kwargs")
    @classmethod
    def _not_grid_kwargs(cls, value: dict[str, Any]) -> dict[str, Any]:
        for k in value:
            if k in GRID_KWARGS:
                raise ValueError(f"field {k!r} is set by the sweep itself ({GRID_KWARGS[k]}); not allowed in --env-kwargs")
        return value
