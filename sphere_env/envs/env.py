"""The one sphere_env Gymnasium environment: a twin composed with a task.

:class:`SphereEnv` owns one :class:`~sphere_env.physics.Twin` per distinct (quantized) incline,
built once and reused by every reset (hydroelastic: one twin for every incline the randomization
can draw, which moves its ground between episodes, so its cached shells serve all inclines);
parameters (pressure, friction scales, ground friction,
payload) change through :meth:`Twin.apply`. It steps the physics with the motor torques its
:class:`~sphere_env.envs.stages.ActionPipeline` makes of each action;
:class:`~sphere_env.envs.parameters.EnvParameters` draws each episode's parameters,
:class:`~sphere_env.envs.observer.EnvObserver` makes the observations (through the
:class:`~sphere_env.envs.stages.SensorPipeline`), and a
:class:`~sphere_env.tasks.Task` supplies the command, reward terms, termination and default
initial state. The registered ids are built by :mod:`sphere_env.envs.factories`.
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any, Mapping

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.utils import EzPickle, seeding

from sphere_env.envs.interface import action_layout, failed_info, read_action, step_info
from sphere_env.envs.kwargs import RENDER_MODES, EnvKwargs, check_ground
from sphere_env.envs.observer import EnvObserver
from sphere_env.envs.parameters import EnvParameters
from sphere_env.envs.stages import ActionPipeline, SensorPipeline, StageContext
from sphere_env.envs.twins import TwinCache, check_above_ground, shared_inclines, twin_config
from sphere_env.physics import InitialState
from sphere_env.schemas import checker, count, validate
from sphere_env.tasks.events import EventManager
from sphere_env.tasks.randomization import RandomizationSpec
from sphere_env.tasks.task import Scene, Task
from sphere_env.tasks.termination import physics_failure

__all__ = ["SphereEnv"]
#: ``reset(seed=...)``: a non-negative integer or None.
_SEED = checker(count(0) | None)


def _meshcat(meshcat: Any, render_mode: str | None, record_replay: bool) -> Any:
    """The env's Meshcat, only when asked: the instance given, else a new one for ``meshcat=True``,
    ``render_mode="human"`` or ``record_replay``; None otherwise."""
    if meshcat is not False and meshcat is not None and not isinstance(meshcat, bool):
        return meshcat
    if meshcat is True or render_mode == "human" or record_replay:
        from sphere_env.physics import start_meshcat

        return start_meshcat()
    return None


class SphereEnv(gym.Env, EzPickle):
    """A Gymnasium environment composing a twin and a task.

    Action ``Box(-1, 1, (2,), float32)`` = [steer, drive] motor torque / limit (+1 drive =
    forward; the applied joint torques are in ``info["motor_torque_nm"]``). Observation: the
    task's :meth:`~sphere_env.tasks.Task.observation_layout` (exported as
    :attr:`observation_layout`). Per-task documentation: :class:`~sphere_env.tasks.RampDescentTask`
    (``sphere_env/RampDescent-v2``), :class:`~sphere_env.tasks.RollTask` (``sphere_env/Roll-v1``).

    :param task: the :class:`~sphere_env.tasks.Task` (command, rewards, termination).

    Keyword arguments common to every sphere_env environment (``gym.make(id, **kwargs)``): the
    fields of :class:`~sphere_env.envs.kwargs.EnvKwargs` (documented there), loaded through it
    before anything is built, so a wrong name, type or value is a ``ValueError`` naming the kwarg.

    **Also refused at construction** (``ValueError`` naming the kwarg): joint friction and injected shell
    torques are explicit, so a friction law whose damping slope (× the largest friction scale the
    randomization can draw), or an injected calibration whose ω_n, would diverge at
    ``time_step_s`` (:meth:`~sphere_env.physics.Twin.explicit_stability_problem`; at 5 ms: viscous
    steer c ≲ 144, drive c ≲ 123 N m s/rad, ω_n ≤ 200 rad/s).

    **Episode protocol.** ``step()`` before a successful ``reset()``, or after an episode ended
    (``terminated``, or ``truncated`` by a physics failure), raises ``RuntimeError``: call
    ``reset()`` (Gymnasium convention). A ``reset()`` that raises changes nothing. ``copy.deepcopy``
    and ``pickle`` rebuild the environment from its constructor arguments: the copy does not carry
    the running episode (Drake's simulator state), and its ``step()`` raises ``RuntimeError`` until
    it is reset; after ``reset(seed=s)`` it behaves exactly like the original reset with ``s``.
    """

    metadata = {"render_modes": list(RENDER_MODES), "render_fps": 50}

    def __init__(self, task: Task, **kwargs: Any):
        meshcat = kwargs.get("meshcat", False)
        # a Meshcat instance cannot be pickled: a copy starts its own
        EzPickle.__init__(self, task, **{**kwargs, "meshcat": meshcat if isinstance(meshcat, bool) else True})
        if not isinstance(task, Task):
            raise ValueError(f"task: value {task!r} must be a sphere_env.tasks.Task")
        kw = validate(EnvKwargs, kwargs, f"{task.name} kwargs")
        check_ground(task, kw.ramp_length_m)
        self.task = task
        self.shell_model = shell_model = kw.shell_model
        self.pressure_extrapolation_kpa = kw.pressure_extrapolation_kpa
        self._parameters = parameters = EnvParameters(task, kw)
        self.calibration = parameters.calibrations.own
        #: the parameter registry resolved against the calibration (the pressure's nominal and bounds)
        self.parameter_space = parameters.space
        self.control_period_s = 1.0 / kw.control_frequency_hz
        self.time_step_s = kw.time_step_s
        self.steer_torque_limit_nm = kw.steer_torque_limit_nm
        self.drive_torque_limit_nm = kw.drive_torque_limit_nm
        self._randomization = parameters.resolve(kw.randomization)  # its stability: once the twin exists
        self.observe_pressure = kw.observe_pressure
        self.observe_shell_model = kw.observe_shell_model
        self.pressure_reading = kw.pressure_reading
        self.observation_noise_scale = kw.observation_noise_scale
        self.incline_deg = kw.incline_deg
        self.ramp_length_m = kw.ramp_length_m
        self.render_mode = render_mode = kw.render_mode
        self.record_replay = record_replay = kw.record_replay
        self.render_size = kw.render_size
        self.metadata = {**self.metadata, "render_fps": kw.control_frequency_hz}

        self.meshcat = _meshcat(meshcat, render_mode, record_replay)

        # ---- spaces ----
        self.action_space = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
        self.observation_history_steps = kw.observation_history_steps
        self.observe_params = kw.observe_params
        self.observation_layout = layout = task.observation_layout(
            kw.observe_pressure, kw.observe_shell_model, kw.observation_history_steps, kw.observe_params
        )
        # the parameters the env applies itself (latency, saturation, noise, ...): envs/stages.py
        context = StageContext(
            (kw.steer_torque_limit_nm, kw.drive_torque_limit_nm), task.observation_layout().noise_std()
        )
        self._actuation = ActionPipeline(context)
        self._observer = EnvObserver(
            task,
            layout,
            SensorPipeline(context),
            shell_model,
            kw.observe_pressure,
            kw.pressure_reading,
            kw.observe_shell_model,
            kw.observe_params,
        )
        self.observation_space = spaces.Box(-np.inf, np.inf, shape=(len(layout),), dtype=np.float32)

        # ---- physics ----
        shared = shared_inclines(self._randomization, shell_model, float(self.incline_deg), self.meshcat)
        self._twin_cache = TwinCache(twin_config(kw, parameters.calibrations.path), self.meshcat, shared)
        self.twin = self._twin_cache.get(self.incline_deg)
        # Friction and injected shell torques are explicit: refuse gains that diverge at this step
        # (at the largest friction scales the randomization can draw).
        problem = self._twin_cache.stability_problem(self._randomization, self.twin, self.incline_deg)
        if problem:
            raise ValueError(problem)
        self._tau = np.zeros(2)
        self._params: dict[str, Any] = {}
        self._events = parameters.event_manager(self._randomization)
        self._next_events: EventManager | None = None  # set_randomization's, from the next reset
        self._fired: list[str] = []
        self._needs_reset = True
        self._ended: str | None = None
        self._copied_mid_episode = False
        self._reward_keys = {k: f"reward_{k}" for k in task.reward_terms}

    # ---- randomization -------------------------------------------------------------------------
    @property
    def randomization(self) -> RandomizationSpec:
        """The randomization spec in force (resolved: pressure bounds filled in from the calibration).
        Assigning to it is :meth:`set_randomization` (validated, effective from the next reset)."""
        return self._randomization

    @randomization.setter
    def randomization(self, spec: Any) -> None:
        self.set_randomization(spec)

    def set_reward_weights(self, overrides: Any) -> Any:
        """Change reward weights from the next step on: ``overrides`` (a mapping term -> weight, e.g.
        ``{"speed_width": 0.5}``) applied over the current weights and validated like the
        ``reward_weights`` kwarg; on a ``ValueError`` (naming the field) nothing changes. Copies carry
        the new weights. Through a vector env: ``venv.env_method("set_reward_weights", overrides)``
        (:class:`sphere_env.training.schedules.RewardSchedule` does so at a given step). Returns the
        new weights."""
        return self.task.set_reward_weights(overrides)

    def set_randomization(self, spec: Any) -> RandomizationSpec:
        """Replace the randomization spec; it takes effect from the next ``reset()`` (the running
        episode keeps its parameters). ``spec`` takes every form of the ``randomization`` kwarg and
        is validated exactly like it: on a ``ValueError`` (naming the field) nothing changes.
        Copies (``copy.deepcopy``, ``pickle``) carry the new spec. Through a vector env:
        ``venv.env_method("set_randomization", spec)``. Returns the resolved spec."""
        resolved = self._parameters.resolve(spec)
        problem = self._twin_cache.stability_problem(resolved, self.twin, self.incline_deg)
        if problem:
            raise ValueError(f"randomization: {problem}")
        events = self._parameters.event_manager(resolved)
        self._randomization = resolved
        self._ezpickle_kwargs["randomization"] = resolved
        self._next_events = events
        return resolved

    @property
    def nominal_params(self) -> dict[str, Any]:
        """Every parameter's value in this env when no event sets it: the registry's nominal values
        resolved against the calibration, and the env's own kwargs (shell model, incline,
        calibration, noise scale)."""
        return self._events.nominal

    @property
    def events(self) -> list[dict[str, Any]]:
        """The events in force (name, mode, parameter), as the event manager describes them."""
        return self._events.describe()

    # ---- twins ---------------------------------------------------------------------------------
    @property
    def ramp_end_x_m(self) -> float:
        """x_W where the current episode's ramp ends [m]; ``inf`` on flat ground."""
        return self.twin.ramp_end_x_m

    @property
    def cached_twin_count(self) -> int:
        """Twins built and kept for reuse (the shared hydroelastic twin, if any, and one per other
        incline drawn)."""
        return len(self._twin_cache.all())

    @property
    def cached_shell_count(self) -> int:
        """Hydroelastic shells (one per distinct pressure) cached over all the env's twins."""
        return sum(t.cached_shell_count for t in self._twin_cache.all())

    # ---- gym API -------------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: Mapping[str, Any] | None = None):
        """Start an episode. ``options`` (all optional):

        * ``initial_state``: :class:`~sphere_env.physics.InitialState` or a mapping of its
          fields (angles rad, rates rad/s, position m, velocities m/s); the sphere centre may sit
          at most :data:`MAX_INITIAL_PENETRATION_M` inside the ground, speeds and rates within the
          physics-failure limits (50 m/s, 500 rad/s per component);
        * any randomization parameter (``pressure_kpa`` [kPa], ``ground_friction``, ...), fixed
          for this episode; ``pressure_rate_kpa_per_s`` [kPa/s] for the schedule;
        * task command values (the task's ``command_options``, within the task's bounds).

        The options load through the task's schema (:func:`~sphere_env.envs.kwargs.reset_options`):
        an unknown option, a string or a bool where a number belongs, a value out of range is a
        ``ValueError`` naming ``options.<name>``. Everything (seed, options, initial state, command
        values) is checked before anything changes: a reset that raises ``ValueError`` leaves the environment as it was (the running
        episode, if any, carries on; a fresh env still needs a successful reset).
        """
        seed = _SEED(seed, "seed")
        options, fixed, init = self._parameters.check_options(options, self.twin)
        # Sample on a copy of the generator; it becomes the env's only once everything passed.
        if seed is not None:
            rng, seed = seeding.np_random(seed)
        else:
            rng = copy.deepcopy(self.np_random)
        events = self._next_events or self._events
        params = events.draw(rng, fixed)
        if init is None:
            init = InitialState(**self.task.initial_state())
        else:
            check_above_ground(self.twin, init, params["incline_deg"], self.ramp_length_m)
        twin = self._twin_cache.get(params["incline_deg"], params["shell_model"])
        # ---- checked: from here on the environment changes ----
        if seed is not None:
            self._np_random, self._np_random_seed = rng, seed
        else:
            self._np_random = rng
        if twin is not self.twin and self.record_replay:
            self.twin.stop_recording()
        self.twin = twin
        self._parameters.apply(twin, params)
        twin.reset(init)
        self._events, self._next_events = events, None
        events.start(params)
        self._params = events.params
        self._fired = [e["name"] for e in events.describe()]  # every term draws at reset
        self._observer.reset(self._params)
        self._actuation.reset(self._params)
        if self.record_replay and twin.is_visualized:
            twin.start_recording()
            twin.publish()
        self._steps = 0
        self._failed = None
        self._ended = None
        self._needs_reset = False
        self._copied_mid_episode = False
        state = twin.state()
        self._tau[:] = 0.0
        self.task.reset(
            state, self.np_random, options, Scene(self.control_period_s, params["incline_deg"], twin.ramp_end_x_m)
        )
        obs = self._observer.observe(state, self._params, self.np_random)
        info = step_info(self.task, state, {}, False, self._params, self._tau, self._fired, self._reward_keys)
        if self.render_mode == "human":
            self.render()
        return obs, info

    def step(self, action):
        a0, a1 = read_action(action)
        if self._needs_reset:
            if self._copied_mid_episode:
                raise RuntimeError(
                    "step: this environment is a copy (copy.deepcopy or pickle) made during an episode; copies "
                    "do not carry the simulator state, call reset() before step()"
                )
            raise RuntimeError("step: call reset() before step() (no episode has started, or the last reset failed)")
        if self._ended is not None:
            raise RuntimeError(f"step: the episode has ended ({self._ended}); call reset() before step()")
        a0 = -1.0 if a0 < -1.0 else (1.0 if a0 > 1.0 else a0)  # clipped to the box
        a1 = -1.0 if a1 < -1.0 else (1.0 if a1 > 1.0 else a1)
        twin = self.twin
        tau = self._tau
        # the torques take the parameters in force when the step starts (before its events fire)
        tau[0], tau[1] = self._actuation(a0, a1, self._params)
        self._fired = []
        if self._failed is None:
            if self._events.active:
                self._apply_events(twin.time_s)
            try:
                twin.advance_unchecked(self.control_period_s, tau)
            except (RuntimeError, ValueError) as err:  # a diverged solve; never propagate
                self._failed = f"physics_failure: {type(err).__name__}: {str(err).splitlines()[0][:200]}"
        self._steps += 1
        if self._failed is None:
            state = twin.state()
            self._failed = physics_failure(state)
        if self._failed is not None:
            self._ended = "truncated: " + self._failed
            info = failed_info(self.task, self._params, self._failed, self._tau, self._fired)
            return self._observer.last.copy(), 0.0, False, True, info
        self._observer.act(a0, a1)
        terms, terminated, success = self.task.step(state, (a0, a1), self.np_random)
        reward = 0.0
        for v in terms.values():
            reward += v
        obs = self._observer.observe(state, self._params, self.np_random)
        info = step_info(self.task, state, terms, success, self._params, self._tau, self._fired, self._reward_keys)
        if terminated:
            self._ended = "terminated"
        if self.render_mode == "human":
            self.render()
        return obs, reward, terminated, False, info

    # ---- pieces ----------------------------------------------------------------------------------
    def _apply_events(self, t: float) -> None:
        """Push the parameters the event manager changed at sim time ``t`` into the twin (the
        stages read the sensing and actuation ones from ``self._params`` when they act); the
        manager's values are clipped to the parameter space, so the twin takes them unchecked."""
        changed, self._fired = self._events.step(t, self.np_random)
        if changed:
            self.twin.apply_unchecked(changed)

    def action_layout(self) -> list[dict[str, Any]]:
        """The action components as :meth:`step` applies them: ``index``, ``name``, the normalized
        ``range`` [-1, 1], the motor ``torque_limit_nm`` at ±1 [N m], the URDF ``joint``, the joint
        torque ``joint_torque_sign`` × a × limit, and the sign convention in words."""
        return action_layout(self.steer_torque_limit_nm, self.drive_torque_limit_nm)

    # ---- rendering / replay -----------------------------------------------------------------------
    def render(self):
        """``human``: Meshcat (published as the sim advances; see the logged URL).
        ``rgb_array``: an (H, W, 3) uint8 frame from Drake's RenderEngineVtk (EGL, headless),
        camera following the robot from behind-left."""
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode= to gym.make")
            return None
        if self.render_mode == "human":
            self.twin.publish()
            return None
        return self.twin.render_rgb(*self.render_size)

    def save_replay(self, path: str | Path) -> Path:
        """Write the current (or just finished) episode as a self-contained Meshcat HTML replay.
        Needs ``record_replay=True``."""
        if not self.record_replay or not self.twin.is_visualized:
            raise RuntimeError("save_replay: make the env with record_replay=True")
        return self.twin.save_recording(path)

    def close(self) -> None:
        self._twin_cache.clear()
        self.meshcat = None

    # ---- copies ------------------------------------------------------------------------------------
    # copy.deepcopy and pickle rebuild the environment from its constructor arguments (EzPickle):
    # the copy has no episode. Drake's state is not only [q; v]: the plant keeps an abstract
    # (C++-only) step memory, e.g. the previous step's contact impulses that the "lagged" contact
    # approximation uses, which cannot be pickled, so a copy could not continue the episode
    # faithfully. A copy made mid-episode remembers that, so its step() says why it needs a reset.
    def __getstate__(self):
        state = EzPickle.__getstate__(self)
        state["_mid_episode"] = not self.__dict__.get("_needs_reset", True)
        return state

    def __setstate__(self, state):
        mid = state.pop("_mid_episode", False)
        EzPickle.__setstate__(self, state)
        self._copied_mid_episode = mid
