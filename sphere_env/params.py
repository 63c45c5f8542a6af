"""The parameter registry: one record per physical or randomizable parameter.

Every layer reads its facts from here: the twin's config checks and setters, the environment's
kwargs and nominal values, and the randomization spec's bounds. A record states the name (with
its unit), the unit, the nominal value, the allowed bounds and when the parameter may change:

* ``step``: at any control step, through the twin's context (no rebuild);
* ``reset``: only between episodes (``incline_deg`` is terrain geometry: another twin);
* ``build``: fixed when the twin or the environment is built.

A record whose nominal value and bounds belong to a context (``bounds_from="calibration"``: the
pressure, whose range is the shell calibration's) is filled in by a :class:`ParameterSpace`, the
registry resolved against that context; the twin, the environment and the event manager check,
clip and read nominal values through one space, so every parameter takes the same path.

Adding a parameter is one record here and its use where it acts: a ``twin`` parameter is checked
and stored by :meth:`~sphere_env.physics.Twin.apply` and pushed into the context where
``Twin._push`` handles it; an ``env`` parameter is applied by its stage in
:mod:`sphere_env.envs.stages`, which reads it from the episode's parameter set (the one
``info["params"]`` reports); a ``randomizable`` one is accepted by the randomization schema,
the reset options and the event manager as its record says.

Pure Python (no Drake), so tasks and randomization specs can be checked without a simulator.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import lru_cache
from typing import Any, Mapping

from sphere_env.parameter import Parameter

#: |g| [m/s²], Drake's default gravity; every model and controller uses this one value.
GRAVITY_M_S2 = 9.81
#: Plant time step [s] of the twin and the environments (see ``evaluation/results/timestep_study.md``).
DEFAULT_TIME_STEP_S = 0.005
#: The finest plant time step [s]. Cost: a simulated second takes 1/time_step_s plant steps of about
#: 0.2-0.5 ms each (measured on the injected shell; the hydroelastic one costs more): 10 000 steps,
#: several seconds of compute, at this bound (50 × the default step's cost); the studies go to 0.5 ms.
MIN_TIME_STEP_S = 1e-4
#: The slowest and fastest policy rates [Hz]. Cost: an episode of the registered length (500-600
#: control steps) lasts 500-600 simulated seconds at 1 Hz; each control step is one policy call.
CONTROL_FREQUENCY_RANGE_HZ = (1.0, 1000.0)
#: The most plant steps one env step may simulate (control period / time step). Cost: about 0.2-0.5 s
#: of compute per env step at this bound (4 plant steps at the defaults).
MAX_PLANT_STEPS_PER_ACTION = 1000
#: The longest episode [simulated s] (control steps x control period). Cost: 300 s / time_step_s plant
#: steps, 60 000 (about 30 s of compute) at the default step; the registered episodes last 8-12 s.
MAX_EPISODE_S = 300.0
#: Coulomb friction coefficient the shell's contact geometry keeps [-]. Drake combines shell and
#: ground coefficients as 2 μ_s μ_g / (μ_s + μ_g), so any effective μ in (0, 2 μ_s) is reachable
#: by changing only the ground's coefficient; that is the ground-friction bound below.
SHELL_FRICTION = 1.0

#: The shell contact models (``docs/design.md`` §5).
SHELL_MODELS = ("point", "injected", "hydroelastic")
#: The shell calibrations shipped in ``assets/calibration`` (a randomization may draw among them).
SHIPPED_CALIBRATIONS = ("default", "free_robot", "hydroelastic_fast", "v0_linear")


def _p(name, unit, nominal, low, high, changes, doc, **kw) -> tuple[str, Parameter]:
    return name, Parameter(name, unit, nominal, low, high, changes, doc, **kw)


#: Every physical or randomizable parameter, by name.
PARAMETERS: dict[str, Parameter] = dict(
    [
        # ---- may change within an episode (context parameters of the twin) ----
        _p(
            "pressure_kpa",
            "kPa",
            None,
            None,
            None,
            "step",
            "shell gauge pressure; nominal and bounds are the shell calibration's",
            applied_by="twin",
            randomizable=True,
            bounds_from="calibration",
        ),
        _p(
            "steer_friction_scale",
            "-",
            1.0,
            0.0,
            10.0,
            "step",
            "× steer joint friction torque",
            applied_by="twin",
            randomizable=True,
        ),
        _p(
            "drive_friction_scale",
            "-",
            1.0,
            0.0,
            10.0,
            "step",
            "× drive joint friction torque",
            applied_by="twin",
            randomizable=True,
        ),
        _p(
            "ground_friction",
            "-",
            SHELL_FRICTION,
            0.0,
            2.0 * SHELL_FRICTION,
            "step",
            "effective shell–ground Coulomb μ (static = dynamic); < 2 μ_shell, see SHELL_FRICTION",
            low_open=True,
            high_open=True,
            applied_by="twin",
            randomizable=True,
        ),
        _p(
            "payload_mass_kg",
            "kg",
            0.0,
            0.0,
            50.0,
            "step",
            "point mass on the pendulum",
            applied_by="twin",
            randomizable=True,
        ),
        _p(
            "payload_com_offset_m",
            "m",
            (0.0, 0.0, 0.0),
            -0.3,
            0.3,
            "step",
            "payload offset from the pendulum COM, pendulum frame",
            size=3,
            applied_by="twin",
            randomizable=True,
        ),
        # The shell law's uncertainty (calibration-aware randomization): the calibrations report
        # intervals for the fitted ω_n, ζ and amplitude stiffness, and the shipped calibrations of
        # the one robot disagree by more (calibration_files.law_scale_intervals). Explicit torques:
        # the twin's stability check covers the largest scales a spec can draw.
        _p(
            "shell_stiffness_scale",
            "-",
            1.0,
            0.25,
            4.0,
            "step",
            "× the shell's steer-direction spring (K_inject, amplitude and quadratic terms); point contact has none",
            applied_by="twin",
            randomizable=True,
        ),
        _p(
            "shell_damping_scale",
            "-",
            1.0,
            0.0,
            4.0,
            "step",
            "× the shell's dampers (C_inject on the steer and drive directions); point contact has none",
            applied_by="twin",
            randomizable=True,
        ),
        _p(
            "pressure_rate_kpa_per_s",
            "kPa/s",
            0.0,
            None,
            None,
            "reset",
            "pressure schedule rate (< 0: a leak), sampled per episode",
        ),
        # ---- sensing and actuation (the environment applies them, the twin never sees them) ----
        # Noise: 100× the default σ (0.5 rad on angles, 5 rad/s on rates) already buries every measured
        # signal; far larger scales overflow the float32 observation to ±inf.
        _p(
            "observation_noise_scale",
            "-",
            0.0,
            0.0,
            100.0,
            "step",
            "× default per-component 1-σ noise of the measured observation components (0 = off); "
            "the env kwarg of that name is the nominal value",
            applied_by="env",
            randomizable=True,
        ),
        _p(
            "action_latency_steps",
            "steps",
            0,
            0,
            5,
            "reset",
            "control steps between an action and its torque (0 = applied at once; zero torque until the "
            "first action arrives)",
            integer=True,
            applied_by="env",
            randomizable=True,
        ),
        _p(
            "motor_torque_scale",
            "-",
            1.0,
            0.0,
            1.0,
            "step",
            "motor saturation: applied |torque| ≤ this × the torque limit (1 = the limit)",
            low_open=True,
            applied_by="env",
            randomizable=True,
        ),
        _p(
            "steer_torque_offset_nm",
            "N m",
            0.0,
            -5.0,
            5.0,
            "step",
            "steer motor torque bias (a current-sensor offset): "
            "added to the commanded torque, the sum within the motor's saturation",
            applied_by="env",
            randomizable=True,
        ),
        # ---- another twin, so only between episodes ----
        _p(
            "shell_model",
            "-",
            None,
            None,
            None,
            "reset",
            "shell contact model; nominal: the env's shell_model kwarg (one twin per model, built on first use)",
            choices=SHELL_MODELS,
            randomizable=True,
        ),
        _p(
            "incline_deg",
            "deg",
            0.0,
            0.0,
            30.0,
            "reset",
            "ground incline, downhill along +x_W; the contact models were checked up to 30°",
            randomizable=True,
        ),
        _p(
            "calibration",
            "-",
            "default",
            None,
            None,
            "reset",
            "shell calibration (a shipped one, by name); nominal: the env's calibration kwarg (default: default)",
            choices=SHIPPED_CALIBRATIONS,
            randomizable=True,
        ),
        # ---- fixed when built ----
        _p(
            "time_step_s",
            "s",
            DEFAULT_TIME_STEP_S,
            MIN_TIME_STEP_S,
            0.05,
            "build",
            "plant time step",
            cost=f"cost: a simulated second takes 1/time_step_s plant steps, {1 / MIN_TIME_STEP_S:.0f} at "
            f"{MIN_TIME_STEP_S:g} s, {1 / DEFAULT_TIME_STEP_S:.0f} at the default",
        ),
        _p(
            "ramp_length_m",
            "m",
            None,
            0.0,
            100.0,
            "build",
            "ramp length along the slope; None = infinite plane",
            low_open=True,
        ),
        _p(
            "control_frequency_hz",
            "Hz",
            50.0,
            *CONTROL_FREQUENCY_RANGE_HZ,
            "build",
            "policy rate",
            cost="cost: an episode of 600 control steps lasts 600 simulated s at 1 Hz, and each control step "
            "is a policy call",
        ),
        # The pressure laws are analytic in p (ω_n linear, ζ exponential, hydroelastic modulus ∝ p,
        # tables held at their end values), so they can be evaluated a little outside the range they were
        # calibrated on; the fault grid does so to test pressures the calibration never saw.
        _p(
            "pressure_extrapolation_kpa",
            "kPa",
            0.0,
            0.0,
            5.0,
            "build",
            "accept pressures this far outside the calibrated range (gauge pressure stays ≥ 0.5 kPa)",
        ),
        # Gravity caps the useful pendulum torque near (m_pc r_pc + m_p r_p) g ≈ 21.9 N m; the steer
        # motor only lifts the pendulum (m_p r_p g ≈ 20.5 N m). Real limits are unpublished.
        _p("steer_torque_limit_nm", "N m", 20.0, 0.0, 200.0, "build", "steer motor torque at action ±1", low_open=True),
        _p("drive_torque_limit_nm", "N m", 22.0, 0.0, 200.0, "build", "drive motor torque at action ±1", low_open=True),
    ]
)

#: Parameters the twin's context takes within an episode (:meth:`Twin.apply`), in registry order.
TWIN_PARAMETERS = tuple(name for name, p in PARAMETERS.items() if p.applied_by == "twin")
#: Parameters a randomization spec or an event may set.
RANDOMIZABLE = tuple(name for name, p in PARAMETERS.items() if p.randomizable)
#: Parameters the environment applies itself (sensing and actuation).
ENV_PARAMETERS = tuple(name for name, p in PARAMETERS.items() if p.applied_by == "env")


def schedule_rate(name: str) -> Parameter:
    """The record of the rate [unit/s] a ``schedule`` term of ``name`` draws once per episode: the
    registry's record of that name when there is one (``pressure_rate_kpa_per_s``, which a reset
    option may fix), else one made from ``name``'s record (unbounded, nominal 0). The name puts
    ``_rate`` before a unit suffix (``payload_mass_kg`` -> ``payload_mass_rate_kg_per_s``) and
    ``_rate_per_s`` after a name without one (``ground_friction_rate_per_s``)."""
    rec = PARAMETERS[name]
    stem, _, suffix = name.rpartition("_")
    unit = rec.unit.lower().replace(" ", "")
    if rec.unit != "-" and suffix == unit:
        rate, per = f"{stem}_rate_{suffix}_per_s", f"{rec.unit}/s"
    else:
        rate, per = f"{name}_rate_per_s", "1/s" if rec.unit == "-" else f"{rec.unit}/s"
    if rate in PARAMETERS:
        return PARAMETERS[rate]
    return Parameter(rate, per, 0.0, None, None, "reset", f"schedule rate of {name}, sampled per episode")


def check(name: str, value: Any, field: str | None = None):
    """Check ``value`` against the record ``name`` (see :meth:`Parameter.check`); a record whose
    bounds come from a context is checked through a :class:`ParameterSpace` instead."""
    return PARAMETERS[name].check(value, field)


@dataclass(frozen=True)
class ParameterSpace:
    """The registry resolved against a context: every record of :data:`PARAMETERS` with its nominal
    value and bounds known. Records marked ``bounds_from="calibration"`` (the pressure) take them
    from the shell calibration (:meth:`for_calibration`); every other record is as registered.

    One path for every parameter: ``space.check(name, value)`` (the value, or a ``ValueError``
    naming the field, the value and the allowed range), ``space.clip(name, value)``,
    ``space.nominal(name)``, ``space.bounds(name)`` and ``space[name]`` (the resolved record).
    """

    records: Mapping[str, Parameter]

    @staticmethod
    @lru_cache(maxsize=64)
    def for_calibration(
        low_kpa: float, high_kpa: float, nominal_kpa: float | None = None, source: str | None = None
    ) -> "ParameterSpace":
        """The space of a shell calibration whose pressure range is [``low_kpa``, ``high_kpa``] and
        nominal pressure ``nominal_kpa`` (None: the middle of the range, as the calibration schema
        defaults it); ``source`` (the calibration's file) is quoted by the pressure's bounds text.
        One space per distinct calibration (cached)."""
        low, high = float(low_kpa), float(high_kpa)
        nominal = 0.5 * (low + high) if nominal_kpa is None else float(nominal_kpa)
        of = "" if source is None else f" (calibration {source})"

        def fill(rec: Parameter) -> Parameter:
            return replace(
                rec,
                nominal=nominal,
                low=low,
                high=high,
                bounds_text=f"[{low}, {high}] {rec.unit}, the calibrated range{of}",
            )

        return ParameterSpace(
            {name: fill(rec) if rec.bounds_from == "calibration" else rec for name, rec in PARAMETERS.items()}
        )

    def __getitem__(self, name: str) -> Parameter:
        return self.records[name]

    def check(self, name: str, value: Any, field: str | None = None):
        """``value`` checked against the resolved record ``name`` (:meth:`Parameter.check`)."""
        return self.records[name].check(value, field)

    def clip(self, name: str, value: Any) -> Any:
        """A drawn value clipped into the bounds of ``name`` (each component of a vector; a
        categorical value unchanged)."""
        rec = self.records[name]
        if rec.choices:
            return value
        if isinstance(value, tuple):
            return tuple(rec.clip(v) for v in value)
        return rec.clip(float(value))

    def nominal(self, name: str) -> Any:
        """The value of ``name`` when nothing sets it."""
        return self.records[name].nominal

    def bounds(self, name: str) -> tuple[float | None, float | None]:
        """(low, high) of ``name`` (None: unbounded on that side)."""
        rec = self.records[name]
        return rec.low, rec.high
