"""The parameters of an environment's episodes, apart from the physics that applies them.

:class:`EnvParameters` holds the parameter registry resolved against the env's calibration, parses
randomization specs and ``reset`` options against it, and builds the event manager that draws each
episode's values (hydroelastic pressures on the env's pressure grid, inclines on the terrain grid).
"""

from __future__ import annotations

from typing import Any, Mapping

from sphere_env.envs.calibrations import EpisodeCalibrations
from sphere_env.envs.kwargs import EnvKwargs, reset_options
from sphere_env.envs.twins import quantize_incline
from sphere_env.params import ENV_PARAMETERS, TWIN_PARAMETERS
from sphere_env.physics import InitialState, Twin
from sphere_env.schemas import validate
from sphere_env.tasks.events import EventManager
from sphere_env.tasks.randomization import PARAMETERS as RANDOMIZED
from sphere_env.tasks.randomization import RandomizationSpec
from sphere_env.tasks.task import Task


class EnvParameters:
    """What the episodes of one environment can set, and the values they start from.

    :param task: the env's task (its ramp bounds the ramp parameters; its options schema).
    :param kw: the env's validated keyword arguments.
    """

    def __init__(self, task: Task, kw: EnvKwargs):
        self.ramp = task.ramp
        self.calibrations = EpisodeCalibrations(kw.calibration, kw.pressure_extrapolation_kpa, f"{task.name} kwargs")
        #: the parameter registry resolved against the calibration (the pressure's nominal and bounds)
        self.space = self.calibrations.own.parameter_space()
        self.options_schema = reset_options(task, self.space)
        self.shell_model = kw.shell_model
        self.incline_deg = kw.incline_deg
        self.observation_noise_scale = kw.observation_noise_scale
        # Hydroelastic pressures are rounded to this grid so re-meshed shells can be cached.
        self.hydro_step_kpa = kw.hydroelastic_pressure_step_kpa

    def resolve(self, spec: Any) -> RandomizationSpec:
        """``spec`` (any form of the ``randomization`` kwarg) parsed and resolved against the
        calibration; raises ``ValueError`` naming the field."""
        return RandomizationSpec.parse(spec, ramp=self.ramp).resolved(self.space)

    def event_manager(self, spec: RandomizationSpec) -> EventManager:
        """The :class:`~sphere_env.tasks.events.EventManager` of ``spec``: every parameter starts at
        its nominal value (the registry's, resolved against the calibration, and the env's own
        kwargs: shell model, incline, noise scale, calibration)."""
        nominal = {
            "shell_model": self.shell_model,
            **{name: self.space.nominal(name) for name in TWIN_PARAMETERS + ENV_PARAMETERS},
            "incline_deg": self.incline_deg,
            "observation_noise_scale": self.observation_noise_scale,
            "calibration": self.calibrations.own_name,
        }
        return EventManager(spec, nominal, self.space, self.quantize_pressure, {"incline_deg": self.snap_incline})

    def apply(self, twin: Twin, params: Mapping[str, Any]) -> None:
        """Give an episode's twin the parameter set drawn at reset: its incline (the ground moves,
        no rebuild), its shell calibration and every parameter its context takes
        (:meth:`~sphere_env.physics.Twin.apply_unchecked`: the values were drawn within the
        parameter space or checked as ``reset`` options, :meth:`check_options`)."""
        twin.set_incline(params["incline_deg"])
        self.calibrations.use(twin, params)
        twin.apply_unchecked(params)

    def snap_incline(self, incline_deg: float) -> float:
        """A drawn incline on the 1° terrain grid (the env's own incline is kept as given)."""
        return incline_deg if incline_deg == self.incline_deg else quantize_incline(incline_deg)

    def quantize_pressure(self, p: float, params: Mapping[str, Any] | None = None) -> float:
        """Round to the hydroelastic pressure grid when the episode's shell model (in ``params``,
        default the env's) is hydroelastic; identity for point/injected [kPa]."""
        shell = (params or {}).get("shell_model") or self.shell_model
        step = self.hydro_step_kpa if shell == "hydroelastic" else 0.0
        if step <= 0.0:
            return p
        lo, hi = self.space.bounds("pressure_kpa")
        q = lo + round((p - lo) / step) * step
        return min(max(round(q, 9), lo), hi)

    def check_options(self, options: Any, twin: Twin) -> tuple[dict[str, Any], dict[str, Any], InitialState | None]:
        """Load the ``reset`` options through the task's options schema
        (:func:`~sphere_env.envs.kwargs.reset_options`) and read the fixed parameter values;
        returns (the options given, fixed parameter values, initial state or None). Pure: raises
        ``ValueError`` naming the option before anything changes (friction scales that would
        diverge at ``twin``'s time step included)."""
        if options is None:
            return {}, {}, None
        loaded = validate(self.options_schema, options, root="options")
        given = loaded.model_dump(exclude_unset=True)
        fixed: dict[str, Any] = {}
        for name, val in given.items():
            if name in RANDOMIZED:  # a fixed value within the space's bounds (the options schema's check)
                fixed[name] = tuple(val) if isinstance(val, list) else val
            elif name == "pressure_rate_kpa_per_s":
                fixed[name] = val
        if "steer_friction_scale" in fixed or "drive_friction_scale" in fixed:
            problem = twin.explicit_stability_problem(
                fixed.get("steer_friction_scale", 1.0), fixed.get("drive_friction_scale", 1.0)
            )
            if problem:
                raise ValueError(f"options: {problem}")
        return given, fixed, loaded.initial_state
