"""The event manager: what a randomization spec sets, and when, within an environment's episodes.

Modelled on Isaac Lab's EventManager. Each term of a
:class:`~sphere_env.tasks.randomization.RandomizationSpec` is an event with a mode and the
parameter it sets (a record of :mod:`sphere_env.params`):

* ``reset``: drawn once when an episode starts;
* ``interval``: drawn at reset and again every ``interval_s`` seconds of sim time;
* ``schedule``: value(t) = value at reset + rate · max(t − delay_s, 0), clipped to the parameter's
  bounds, its rate drawn at reset: any numeric scalar parameter that may change within an episode
  (``Parameter.schedulable``). The pressure's (p₀ + rate · ..., a leak when negative, within the
  calibration's range) is given as ``pressure_schedule`` or as ``pressure_kpa``'s mode
  ``schedule``; it is pushed only when it moved by :data:`PRESSURE_RESOLUTION_KPA` and snaps to the
  hydroelastic grid. Every other scheduled value is set at each control step at which it changed.

The environment asks the manager for an episode's parameter set at reset (:meth:`draw`, checked,
then :meth:`start`: a reset that fails changes nothing) and, when
:attr:`active`, for what changed before each control step (:meth:`step`); it applies the values
(the twin's context, or its own sensing and actuation) and reports the set in ``info["params"]``
and the events that fired in ``info["events"]``. Every draw takes the environment's generator, in
a fixed order, so an episode is reproducible from its reset seed. Pure numpy: no simulator.
"""

from __future__ import annotations

from typing import Any, Callable, Mapping

import numpy as np

from sphere_env.params import PARAMETERS, ParameterSpace, schedule_rate
from sphere_env.tasks.randomization import RandomizationSpec, schedule_pressure, schedule_value

#: The record of the pressure schedule's rate, which ``info["params"]`` always reports (0: none).
PRESSURE_RATE = schedule_rate("pressure_kpa").name
#: The pressure schedule pushes a new pressure when it moved by at least this much [kPa].
#: Hydroelastic pressures additionally snap to the environment's pressure grid: re-meshing the
#: compliant shell costs ≈90 ms, restoring a cached mesh ≈2 ms.
PRESSURE_RESOLUTION_KPA = 0.01


class EventManager:
    """Draws and updates one episode's parameter set from a resolved spec.

    :param spec: the resolved :class:`RandomizationSpec` (pressure bounds filled in).
    :param nominal: every parameter's value when no event sets it (the space's nominal values;
        env-applied parameters: the environment's kwargs).
    :param space: the parameter space (:class:`~sphere_env.params.ParameterSpace`, resolved
        against the shell calibration) whose bounds drawn values are clipped to.
    :param quantize_pressure: ``(pressure, episode parameters) -> pressure``: rounds a pressure to
        the values the episode's twin can take (the hydroelastic grid; identity otherwise), applied
        to every pressure an event sets.
    :param quantizers: per parameter, a function applied to each value drawn at reset (the
        environment snaps inclines to its terrain grid).
    """

    def __init__(
        self,
        spec: RandomizationSpec,
        nominal: Mapping[str, Any],
        space: ParameterSpace,
        quantize_pressure: Callable[[float, Mapping[str, Any]], float] = lambda p, params: p,
        quantizers: Mapping[str, Callable[[Any], Any]] | None = None,
    ):
        self.spec = spec
        self._nominal = dict(nominal)
        self._space = space
        self._quantize = quantize_pressure
        self._quantizers = dict(quantizers or {})
        self._intervals = [t for t in spec.terms if t.mode == "interval"]
        #: (parameter, the name of its rate in the parameter set, the rate's distribution, delay [s]) of
        #: every schedule, in the order their rates are drawn: the terms', then ``pressure_schedule``'s
        self._schedules = [
            (t.parameter, schedule_rate(t.parameter).name, t.rate_per_s, t.delay_s)
            for t in spec.terms
            if t.mode == "schedule"
        ]
        if spec.pressure_schedule is not None:
            sched = spec.pressure_schedule
            self._schedules.append(("pressure_kpa", PRESSURE_RATE, sched.rate_kpa_per_s, sched.delay_s))
        self._pressure_delay_s = next((d for name, _, _, d in self._schedules if name == "pressure_kpa"), 0.0)
        #: the schedules of every other parameter: (parameter, rate name, delay [s])
        self._ramps = [(name, rate, d) for name, rate, _, d in self._schedules if name != "pressure_kpa"]
        self.params: dict[str, Any] = {}
        self._next_s: dict[str, float] = {}
        self._start_values: dict[str, float] = {}
        self._p0 = self._p_applied = 0.0
        self._delay_s = 0.0
        self.active = False

    @property
    def nominal(self) -> dict[str, Any]:
        """Every parameter's value when no event sets it."""
        return dict(self._nominal)

    def describe(self) -> list[dict[str, Any]]:
        """The events as data: name, mode, parameter (and interval, or schedule delay)."""

        def timing(t) -> dict[str, Any]:
            if t.mode == "interval":
                return {"interval_s": t.interval_s}
            return {"delay_s": t.delay_s} if t.mode == "schedule" else {}

        out = [
            {"name": f"{t.mode}:{t.parameter}", "mode": t.mode, "parameter": t.parameter, **timing(t)}
            for t in self.spec.terms
        ]
        if self.spec.pressure_schedule is not None:
            out.append(
                {
                    "name": "schedule:pressure_kpa",
                    "mode": "schedule",
                    "parameter": "pressure_kpa",
                    "delay_s": self.spec.pressure_schedule.delay_s,
                }
            )
        return out

    def draw(self, rng: np.random.Generator, fixed: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """A new episode's parameter set, without starting it (pure but for ``rng``): nominal
        values, then every term's value drawn from ``rng`` in the spec's order (each through the
        environment's quantizer for that parameter, if any), then the schedules' rates (the schedule
        terms' in the spec's order, ``pressure_schedule``'s last), then ``fixed`` (checked ``reset``
        options) on top; pressures snap to the twin's grid last."""
        params = dict(self._nominal)
        for name, val in self.spec.sample(rng).items():
            val = self._space.clip(name, val)
            params[name] = self._quantizers[name](val) if name in self._quantizers else val
        params[PRESSURE_RATE] = 0.0
        for _, rate_name, rate, _ in self._schedules:
            params[rate_name] = float(rate.sample(rng, 1))
        params.update(fixed or {})
        params["pressure_kpa"] = self._quantize(params["pressure_kpa"], params)
        for name in _INTEGER:
            if name in params:
                params[name] = int(round(params[name]))
        return params

    def start(self, params: Mapping[str, Any]) -> None:
        """Start an episode with a set :meth:`draw` gave: it becomes :attr:`params`, and interval
        and schedule events count from sim time 0."""
        self.params = dict(params)
        self._p0 = self._p_applied = self.params["pressure_kpa"]
        self._delay_s = self._pressure_delay_s
        self._next_s = {t.parameter: t.interval_s for t in self._intervals}
        self._start_values = {name: self.params[name] for name, _, _ in self._ramps}
        self.active = (
            bool(self._intervals)
            or self.params[PRESSURE_RATE] != 0.0
            or any(self.params[rate] != 0.0 for _, rate, _ in self._ramps)
        )

    def step(self, time_s: float, rng: np.random.Generator) -> tuple[dict[str, Any], list[str]]:
        """Events due at sim time ``time_s`` [s]: (the parameters that changed, with their new
        values; the names of the events that fired). :attr:`params` is updated. A scheduled value
        is set when it changed; a pressure the schedule moved by less than
        :data:`PRESSURE_RESOLUTION_KPA` is not pushed."""
        params, changed, fired = self.params, {}, []
        for term in self._intervals:
            due = self._next_s[term.parameter]
            if time_s >= due - 1e-9:
                val = term.distribution.sample(rng, PARAMETERS[term.parameter].size)
                val = self._space.clip(term.parameter, val)
                if term.parameter == "pressure_kpa":
                    val = self._quantize(val, params)
                    self._p0 = val
                    self._delay_s = time_s  # the schedule continues from the new value
                params[term.parameter] = changed[term.parameter] = val
                self._next_s[term.parameter] = due + term.interval_s
                fired.append(f"interval:{term.parameter}")
        for name, rate_name, delay_s in self._ramps:
            rate = params[rate_name]
            if rate != 0.0:
                val = schedule_value(name, self._start_values[name], rate, delay_s, time_s, self._space)
                if val != params[name]:
                    params[name] = changed[name] = val
                    fired.append(f"schedule:{name}")
        rate = params[PRESSURE_RATE]
        if rate != 0.0:
            p = self._quantize(schedule_pressure(self._p0, rate, self._delay_s, time_s, self._space), params)
            if abs(p - self._p_applied) >= PRESSURE_RESOLUTION_KPA:
                self._p_applied = changed["pressure_kpa"] = p
                fired.append("schedule:pressure_kpa")
            elif "pressure_kpa" in changed:
                changed["pressure_kpa"] = self._p_applied
            params["pressure_kpa"] = self._p_applied  # what the physics uses
        elif "pressure_kpa" in changed:
            self._p_applied = changed["pressure_kpa"]
        for name in _INTEGER:
            if name in changed:
                params[name] = changed[name] = int(round(changed[name]))
        return changed, fired


_INTEGER = tuple(name for name, rec in PARAMETERS.items() if rec.integer)
