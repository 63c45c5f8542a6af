"""The digital twin: the robot URDF in a Drake diagram with selectable friction and shell models.

Frames and signs: :mod:`sphere_env.physics.config`. The diagram is built by
:mod:`sphere_env.physics.diagram`, the ground by :mod:`sphere_env.physics.terrain`, views by
:mod:`sphere_env.physics.render`; the state is read by :mod:`sphere_env.physics.state` and the
explicit-torque margins judged by :mod:`sphere_env.physics.admissibility`. :class:`Twin` itself
holds the context: its parameters (pressure, friction, payload, incline), reset and stepping.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import Any, Mapping

import numpy as np
from pydrake.geometry import CollisionFilterDeclaration, GeometrySet, ProximityProperties, RoleAssign
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.multibody.math import SpatialVelocity
from pydrake.multibody.plant import CoulombFriction
from pydrake.multibody.tree import SpatialInertia, UnitInertia

from sphere_env.files import write_text_atomic
from sphere_env.models.rigid_body import DEFAULT_URDF, RobotParameters
from sphere_env.models.shell import ShellCalibration
from sphere_env.params import TWIN_PARAMETERS
from sphere_env.physics.admissibility import ExplicitStability
from sphere_env.physics.config import InitialState, TwinConfig, TwinState
from sphere_env.physics.diagram import (
    build_diagram,
    ground_coefficient,
    hydroelastic_resolution_hint_m,
    shell_properties,
)
from sphere_env.physics.render import RgbCamera
from sphere_env.physics.shell_cache import ShellCache
from sphere_env.physics.state import read_state
from sphere_env.physics.terrain import Terrain

_log = logging.getLogger("sphere_env")


#: The parameters whose change re-sets the force system's gain vector.
_GAIN_PARAMETERS = ("steer_friction_scale", "drive_friction_scale", "shell_stiffness_scale", "shell_damping_scale")


class Twin:
    """The robot in Drake, advanced in chunks like an environment would.

    >>> twin = Twin(TwinConfig(shell_model="injected", incline_deg=16))
    >>> twin.reset(InitialState())
    >>> twin.advance(0.02, motor_torque_nm=(0.0, 0.0)); twin.state().omega_d
    """

    def __init__(self, config: TwinConfig | None = None, meshcat=None, **kwargs):
        config = config.replace(**kwargs) if config is not None and kwargs else (config or TwinConfig(**kwargs))
        self.config = config
        # k_d refitted at this step, if the calibration has one (Drake's contact damping depends on it)
        self.calibration = self._own(ShellCalibration.load(config.calibration))
        self.robot = RobotParameters.from_urdf(config.urdf or DEFAULT_URDF)
        self.shell = self.calibration.bind(self.robot)  # the shell laws, evaluated for this robot
        # Every context parameter (TWIN_PARAMETERS), in one dict: nominal values from the parameter
        # space, the pressure and ground friction the config gives. Twin.apply changes them.
        space = self.calibration.parameter_space()
        self._params: dict[str, Any] = {name: space.nominal(name) for name in TWIN_PARAMETERS}
        if config.pressure_kpa is not None:
            self._params["pressure_kpa"] = space.check("pressure_kpa", config.pressure_kpa)
        self._params["ground_friction"] = float(config.ground_friction)
        self.terrain = Terrain(config.incline_deg, config.ramp_length_m)
        fitted = self.calibration.fitted_time_step_s
        if config.shell_model == "hydroelastic" and fitted is not None and not math.isclose(fitted, config.time_step_s):
            _log.warning(
                "time_step_s=%g s differs from the %g s at which the calibration's hydroelastic dissipation "
                "was fitted; Drake's numerical contact damping depends on the step, so the shell's damping "
                "ratio will differ (see evaluation/results/timestep_study.md). Refit k_d at this step "
                "(hydroelastic.k_d_by_time_step; python -m sphere_env.calibration kd-step).",
                config.time_step_s,
                fitted,
            )
        self.meshcat = meshcat
        self._build()

    # ---- building --------------------------------------------------------------------------------
    def _build(self) -> None:
        shell = shell_properties(self.config, self.shell, self.pressure_kpa)
        d = build_diagram(self.config, self.robot, self.terrain, shell, self.meshcat)
        # Drake handles, public for tools that inspect the plant (calibration, tests); the env and
        # tasks use the methods below instead.
        self.diagram, self.simulator, self.context = d.diagram, d.simulator, d.context
        self.plant, self.scene_graph = d.plant, d.scene_graph
        self.plant_context, self.sg_context = d.plant_context, d.sg_context
        self.model_instance, self.pc, self.pipe, self.pendulum = d.model_instance, d.pc, d.pipe, d.pendulum
        self.planar, self.steer, self.drive = d.planar, d.steer, d.drive
        self.shell_geometry, self.shell_source_id = d.shell_geometry, d.shell_source_id
        self.visualizer = d.visualizer
        self._ground_ids = d.ground_ids
        self._kinematics_ports, self._kinematics_switch = d.kinematics_ports, d.kinematics_switch
        self._switch_context = (
            None if d.kinematics_switch is None else d.kinematics_switch.GetMyMutableContextFromRoot(self.context)
        )
        self._ground_geometries: dict[float, list] = {}  # incline -> Terrain.geometries(), built once
        # The ground in the context: its incline and μ. Setters change the targets (config
        # incline, the ground_friction parameter) and mark it dirty; _sync_ground brings the context there
        # before the next reset, step or render, so a cached shell restored in between (which
        # brings the ground of its time) costs one update, not two.
        self._ground_incline = self.incline_deg
        self._ground_mu_in_context = float(self.config.ground_friction)
        self._ground_dirty = False
        self._select_kinematics()
        self._layout = d.layout
        self._forces, self._forces_context = d.forces, d.forces_context
        # The motor torques are fixed on the input port once; each step writes the new values into
        # that FixedInputPortValue (GetMutableData notifies the dependents, as a new FixValue would),
        # which takes half the time of a FixValue (that allocates a new value every call).
        self._motor_value = d.motor_port.FixValue(self.context, np.zeros(2))
        self._pendulum_inertia = self.pendulum.default_spatial_inertia()
        self._shells = ShellCache(self.sg_context)
        self._camera: RgbCamera | None = None
        self._apply_pressure_to_context()
        self.reset()

    # ---- incline ---------------------------------------------------------------------------------
    @property
    def incline_deg(self) -> float:
        """The current ground incline [deg] (``config.incline_deg``)."""
        return float(self.config.incline_deg)

    @property
    def inclines_deg(self) -> tuple[float, ...]:
        """Inclines [deg] this twin can switch to with :meth:`set_incline`."""
        return self.config.inclines_deg or (self.incline_deg,)

    def set_incline(self, incline_deg: float) -> None:
        """Move the ground to another of :attr:`inclines_deg` (no rebuild); takes effect on the
        next step, use :meth:`reset` to start on it.

        The ground geometries get the new incline's poses in the SceneGraph context (Drake's
        ``ChangeShape``; a twin with several inclines carries its ground on a body welded to the
        world, since anchored geometry cannot be moved in a context), the shell-kinematics system
        of that incline is selected, and the terrain (normal, ramp end) follows. The results are
        bit-identical to a twin built at that incline.
        """
        inc = self.calibration.parameter_space().check("incline_deg", incline_deg)
        if inc not in self.inclines_deg:
            raise ValueError(
                f"incline_deg: value {incline_deg!r} is not one this twin was built for; allowed: "
                f"{list(self.inclines_deg)} (TwinConfig.inclines_deg)"
            )
        if inc == self.incline_deg:
            return
        self.config = self.config.model_copy(update={"incline_deg": inc})  # checked above: one of inclines_deg
        self.terrain = Terrain(inc, self.config.ramp_length_m)
        self._select_kinematics()
        self._ground_dirty = True  # the ground moves before the next reset, step or render

    def _sync_ground(self) -> None:
        """Bring the context's ground to the current incline and μ (see ``_ground_dirty``)."""
        self._ground_dirty = False
        mu = self._params["ground_friction"]
        if self._ground_mu_in_context != mu:
            self._assign_ground_friction(mu)
            self._ground_mu_in_context = mu
        inc = self.config.incline_deg
        if self._ground_incline == inc:
            return
        geometries = self._ground_geometries.get(inc)
        if geometries is None:
            geometries = self._ground_geometries[inc] = self.terrain.geometries()
        for name, X_BG, shape, _ in geometries:
            self.scene_graph.ChangeShape(self.sg_context, self.shell_source_id, self._ground_ids[name], shape, X_BG)
        # ChangeShape re-adds the geometry to the proximity engine without the filter that keeps
        # geometries of one body from colliding with each other: declare it again.
        self.scene_graph.collision_filter_manager(self.sg_context).Apply(
            CollisionFilterDeclaration().ExcludeWithin(GeometrySet(list(self._ground_ids.values())))
        )
        self._ground_incline = inc

    def _select_kinematics(self) -> None:
        if self._kinematics_switch is not None:
            self._kinematics_switch.get_port_selector_input_port().FixValue(
                self._switch_context, self._kinematics_ports[self.incline_deg]
            )

    # ---- parameters: pressure, friction, payload ---------------------------------------------------
    GEOMETRY_CACHE_SIZE = 24  # hydroelastic shells kept per twin, one per distinct pressure

    @property
    def pressure_kpa(self) -> float:
        return self._params["pressure_kpa"]

    @property
    def params(self) -> dict:
        """The context's current parameter values (the registry's ``TWIN_PARAMETERS``), a copy."""
        return dict(self._params)

    def shell_parameters(self, pressure_kpa: float | None = None) -> dict:
        """The shell model's parameters at a pressure (current by default), with units in the keys."""
        p = self.pressure_kpa if pressure_kpa is None else pressure_kpa
        return self.shell.parameters(self.config.shell_model, p)

    def apply(self, params: Mapping[str, Any]) -> None:
        """Change parameter values; the one path by which the twin's parameters change.

        Keys: any of :data:`~sphere_env.params.TWIN_PARAMETERS` (``pressure_kpa``,
        ``steer_friction_scale``, ``drive_friction_scale``, ``ground_friction``,
        ``payload_mass_kg``, ``payload_com_offset_m``); other keys are ignored. All values are
        checked first, through the calibration's parameter space
        (:meth:`~sphere_env.models.shell.ShellCalibration.parameter_space`): on error nothing
        changes. Then the values that changed are pushed into the context (cheap per step) and take
        effect on the next step.
        """
        space = self.calibration.parameter_space()
        self.apply_unchecked({k: space.check(k, params[k]) for k in TWIN_PARAMETERS if k in params})

    def apply_unchecked(self, params: Mapping[str, Any]) -> None:
        """:meth:`apply` without the check: every value of a key of
        :data:`~sphere_env.params.TWIN_PARAMETERS` must already be within this twin's parameter
        space, in the form :meth:`~sphere_env.params.ParameterSpace.check` gives (a float, a tuple
        for a vector). The environment's episode values are (drawn and clipped, or checked as
        ``reset`` options); the values that changed are pushed."""
        held = self._params
        self._push({k: params[k] for k in TWIN_PARAMETERS if k in params and params[k] != held[k]})

    def _push(self, changed: Mapping[str, Any]) -> None:
        """Store checked values and bring the context to them. Pressure goes last: its push sets the
        shell gains with the friction scales already stored and snapshots a hydroelastic shell with
        the ground in force (the order the setters always had, so results stay bit-identical)."""
        self._params.update(changed)
        if any(k in changed for k in _GAIN_PARAMETERS):
            self._apply_gains()
        if "ground_friction" in changed:
            self._ground_dirty = True  # pushed before the next reset, step or render
        if "payload_mass_kg" in changed or "payload_com_offset_m" in changed:
            self._push_payload(self._params["payload_mass_kg"], np.asarray(self._params["payload_com_offset_m"]))
        if "pressure_kpa" in changed:
            self._apply_pressure_to_context()

    def set_pressure(self, pressure_kpa: float) -> None:
        """Change the inflation pressure [kPa gauge] now (:meth:`apply`); takes effect on the next step.

        ``injected`` reads new K_inject, C_inject from the context; ``hydroelastic`` replaces the
        shell's proximity properties (modulus, dissipation) in the SceneGraph context.
        """
        self.apply({"pressure_kpa": pressure_kpa})

    def set_calibration(self, calibration: ShellCalibration | str | Path, pressure_kpa: float | None = None) -> None:
        """Use another shell calibration from now on (no rebuild), at ``pressure_kpa`` [kPa] or the
        current pressure. Validated first (the pressure in the new calibration's parameter space): on
        error nothing changes."""
        cal = self._own(
            calibration if isinstance(calibration, ShellCalibration) else ShellCalibration.load(calibration)
        )
        p = cal.parameter_space().check("pressure_kpa", self.pressure_kpa if pressure_kpa is None else pressure_kpa)
        shell = cal.bind(self.robot)
        self.calibration, self.shell = cal, shell
        self._push({"pressure_kpa": p})  # pushed even when unchanged: the shell laws are new

    def _own(self, calibration: ShellCalibration) -> ShellCalibration:
        """``calibration`` as this twin uses it: the k_d refitted at its step, if the calibration has
        one (Drake's contact damping depends on it), widened by its pressure margin, and without the
        drive law unless the config applies it."""
        cal = calibration.for_time_step(self.config.time_step_s).extrapolated(self.config.pressure_extrapolation_kpa)
        return cal if self.config.calibration_drive_law else cal.without_drive_law()

    def set_friction_scale(self, steer: float = 1.0, drive: float = 1.0) -> None:
        """Scale each joint's friction torque (domain randomization); 1 = nominal (:meth:`apply`)."""
        self.apply({"steer_friction_scale": steer, "drive_friction_scale": drive})

    def set_shell_law_scale(self, stiffness: float = 1.0, damping: float = 1.0) -> None:
        """Scale the shell's springs and dampers (the shell law's uncertainty); 1 = the calibration's
        (:meth:`apply`)."""
        self.apply({"shell_stiffness_scale": stiffness, "shell_damping_scale": damping})

    def _apply_gains(self) -> None:
        if self._forces is None:  # bare plant
            return
        law = self.shell.law_gains(self.config.shell_model, self.pressure_kpa)
        # the shell law's uncertainty: springs × shell_stiffness_scale, dampers × shell_damping_scale
        # (LAW_GAIN_NAMES: K_inject, C_steer, C_drive, rest angle, amplitude torque, 1/scale, K_2)
        k, c = self._params["shell_stiffness_scale"], self._params["shell_damping_scale"]
        law = law * np.array([k, c, c, 1.0, k, 1.0, k])
        # the calibration's drive law for this shell model: spin damping, × the drive friction law
        drive = self.calibration.drive_law_of(self.config.shell_model)
        spin = drive.spin_damping_nms_per_rad
        scales = [self._params["steer_friction_scale"], self._params["drive_friction_scale"] * drive.friction_scale]
        self._forces_context.get_mutable_numeric_parameter(0).SetFromVector(np.concatenate([law, [c * spin], scales]))

    def _apply_pressure_to_context(self) -> None:
        """Push the current pressure into the context.

        injected: new K_inject, C_inject gains. hydroelastic: new shell proximity properties
        (modulus, dissipation) via ``AssignRole(kReplace)``; Drake re-meshes the compliant shell for
        that, and the result is kept per shell (:class:`~sphere_env.physics.shell_cache.ShellCache`)
        and restored when the shell recurs, the current ground friction and incline re-applied
        after a restore.
        """
        self._apply_gains()
        if self.config.shell_model != "hydroelastic":
            return
        p = self.pressure_kpa
        # a shell is its modulus, dissipation and mesh (the mesh may change with pressure)
        key = (*self.shell.hydroelastic(p), hydroelastic_resolution_hint_m(self.config, self.shell, p))
        ground = self._shells.restore(key)
        if ground is not None:
            # The snapshot holds the ground (pose, μ) of its time: synced before the next step.
            self._ground_mu_in_context, self._ground_incline = ground
            self._ground_dirty = True
            return
        self.scene_graph.AssignRole(
            self.sg_context,
            self.shell_source_id,
            self.shell_geometry,
            shell_properties(self.config, self.shell, p),
            RoleAssign.kReplace,
        )
        self._shells.store(key, self._ground_mu_in_context, self._ground_incline, self.GEOMETRY_CACHE_SIZE)

    def set_payload(self, mass_kg: float = 0.0, offset_m=(0.0, 0.0, 0.0)) -> None:
        """Add a point-mass payload to the pendulum, at its nominal COM shifted by ``offset_m``
        (pendulum frame, m). ``mass_kg = 0`` restores the URDF inertia. Context parameters only
        (:meth:`apply`): no rebuild; survives :meth:`reset`."""
        self.apply({"payload_mass_kg": mass_kg, "payload_com_offset_m": offset_m})

    def _push_payload(self, m: float, off: np.ndarray) -> None:
        M0 = self._pendulum_inertia
        M = SpatialInertia(M0.get_mass(), M0.get_com(), M0.get_unit_inertia())
        if m > 0.0:
            p = M0.get_com() + off
            M += SpatialInertia(m, p, UnitInertia.PointMass(p))
        self.pendulum.SetSpatialInertiaInBodyFrame(self.plant_context, M)

    def set_ground_friction(self, mu: float) -> None:
        """Set the effective shell–ground Coulomb friction [-] (static = dynamic) (:meth:`apply`);
        pushed into the context before the next reset, step or render.

        Drake combines the two geometries' coefficients as 2 μ_s μ_g / (μ_s + μ_g); the shell keeps
        μ_s = :data:`~sphere_env.params.SHELL_FRICTION`, so the ground's value is solved for:
        μ_g = μ μ_s / (2 μ_s − μ). Allowed: 0 < μ < 2 μ_s (the registry's bounds).
        """
        self.apply({"ground_friction": mu})

    def _assign_ground_friction(self, mu: float) -> None:
        mu_g = ground_coefficient(mu)
        inspector = self.scene_graph.model_inspector()
        for gid in self._ground_ids.values():
            if inspector.GetProximityProperties(gid) is None:
                continue  # visual ground
            props = ProximityProperties(inspector.GetProximityProperties(gid))
            props.UpdateProperty("material", "coulomb_friction", CoulombFriction(mu_g, mu_g))
            self.scene_graph.AssignRole(self.sg_context, self.shell_source_id, gid, props, RoleAssign.kReplace)

    @property
    def cached_shell_count(self) -> int:
        """Hydroelastic shells (one per distinct modulus, dissipation, mesh) cached in this twin."""
        return len(self._shells)

    def clear_shell_cache(self) -> None:
        """Forget cached hydroelastic shells: the next pressure change re-meshes."""
        self._shells.clear()

    # ---- numerical admissibility ------------------------------------------------------------------
    def explicit_stability_problem(
        self,
        steer_friction_scale: float = 1.0,
        drive_friction_scale: float = 1.0,
        shell_stiffness_scale: float = 1.0,
        shell_damping_scale: float = 1.0,
    ) -> str | None:
        """Why this twin's explicit torques would diverge at its time step, or ``None``.

        Checks the joint friction slopes (× the given scales) against
        :data:`~sphere_env.physics.admissibility.EXPLICIT_DAMPING_LIMIT` and, for the injected shell,
        ω_n·dt over the calibration's pressure range against
        :data:`~sphere_env.physics.admissibility.INJECTED_OMEGA_DT_LIMIT` and the drive-direction
        damping C_inject (which acts on the drive joint) together with the drive friction; the
        margins are computed on the first call (:class:`~sphere_env.physics.admissibility.ExplicitStability`).
        """
        stability = self.__dict__.get("_stability")
        if stability is None:
            stability = self._stability = ExplicitStability(
                self.plant, self._layout, self.config, self.calibration, self.shell
            )
        return stability.problem(steer_friction_scale, drive_friction_scale, shell_stiffness_scale, shell_damping_scale)

    # ---- state -----------------------------------------------------------------------------------
    def reset(self, initial: InitialState | None = None, pressure_kpa: float | None = None) -> TwinState:
        """Reset time and state (the diagram is reused). Pressure is kept unless given."""
        initial = initial if initial is not None else InitialState()
        if pressure_kpa is not None:  # checked before anything changes, pushed once the state is set
            pressure_kpa = self.calibration.parameter_space().check("pressure_kpa", pressure_kpa)
        self.context.SetTime(0.0)
        plant, pc = self.plant, self.plant_context
        plant.SetDefaultState(pc, pc.get_mutable_state())
        lay = self._layout
        for joint in (self.steer, self.drive):
            joint.Unlock(pc)
        if lay["steer_locked"]:
            self.steer.set_angle(pc, 0.0)
            self.steer.Lock(pc)
        else:
            self.steer.set_angle(pc, initial.theta)
            self.steer.set_angular_rate(pc, initial.theta_dot)
        self.drive.set_angle(pc, initial.drive_angle)
        if lay["drive_locked"]:
            self.drive.Lock(pc)
        else:
            self.drive.set_angular_rate(pc, initial.drive_rate)
        R = self.robot.radius_m
        if lay["base"] == "quaternion":
            p = np.asarray(initial.position_m, float) if initial.position_m is not None else R * self.terrain.n_ramp
            R_WPC = RotationMatrix(RollPitchYaw(initial.roll, initial.pitch, initial.heading))
            plant.SetFreeBodyPose(pc, self.pc, RigidTransform(R_WPC, p))
            V = SpatialVelocity(
                np.asarray(initial.angular_velocity_rad_s, float), np.asarray(initial.velocity_m_s, float)
            )
            plant.SetFreeBodySpatialVelocity(pc, self.pc, V)
        elif lay["base"] == "planar":
            p = np.asarray(initial.position_m, float) if initial.position_m is not None else np.array([0.0, 0.0, R])
            self.planar.set_translation(pc, [p[1], p[2]])
            self.planar.set_rotation(pc, initial.roll)
            self.planar.set_translational_velocity(pc, [initial.velocity_m_s[1], initial.velocity_m_s[2]])
            self.planar.set_angular_velocity(pc, initial.angular_velocity_rad_s[0])
        if pressure_kpa is not None:
            self.apply_unchecked({"pressure_kpa": pressure_kpa})
        self._sync_ground()
        self._set_motor_torque(np.zeros(2))
        self.simulator.Initialize()
        return self.state()

    def lock_joints(self, steer: bool = False, drive: bool = False) -> None:
        """Lock joints at their current angle (a brake) until the next ``reset``."""
        for joint, flag in ((self.steer, steer), (self.drive, drive)):
            if flag:
                joint.set_angular_rate(self.plant_context, 0.0)
                joint.Lock(self.plant_context)

    def advance(self, duration_s: float, motor_torque_nm=(0.0, 0.0)) -> None:
        """Hold motor torques [τ_steer, τ_drive] (N m at the joints) for ``duration_s`` seconds."""
        tau = np.asarray(motor_torque_nm, dtype=float)
        if tau.shape != (2,) or not np.all(np.isfinite(tau)):
            raise ValueError(f"motor_torque_nm: value {motor_torque_nm!r} must be 2 finite numbers [N m]")
        self.advance_unchecked(duration_s, tau)

    def positions_velocities(self) -> tuple[np.ndarray, np.ndarray]:
        return self.plant.GetPositions(self.plant_context), self.plant.GetVelocities(self.plant_context)

    def state(self) -> TwinState:
        """Read θ, φ, ω_d, heading, pose and rates from the plant state (names and signs: docs/design.md;
        the math: :func:`~sphere_env.physics.state.read_state`)."""
        return read_state(
            self.plant.GetPositionsAndVelocities(self.plant_context),
            self._layout,
            self.terrain,
            self.context.get_time(),
            self.pressure_kpa,
        )

    def advance_unchecked(self, duration_s: float, motor_torque_nm: np.ndarray) -> None:
        """:meth:`advance` without input validation; ``motor_torque_nm`` must be a finite float64 (2,)."""
        if self._ground_dirty:
            self._sync_ground()
        self._motor_value.GetMutableData().get_mutable_value().SetFromVector(motor_torque_nm)
        self.simulator.AdvanceTo(self.context.get_time() + duration_s)

    def _set_motor_torque(self, motor_torque_nm: np.ndarray) -> None:
        """Hold ``motor_torque_nm`` [τ_steer, τ_drive] (N m) on the motor input port."""
        self._motor_value.GetMutableData().get_mutable_value().SetFromVector(motor_torque_nm)

    # ---- time and terrain -------------------------------------------------------------------------
    @property
    def time_s(self) -> float:
        """Simulated time since the last :meth:`reset` [s]."""
        return self.context.get_time()

    @property
    def ramp_end_x_m(self) -> float:
        """x_W where the ramp ends and the flat run-out starts [m]; ``inf`` without a ramp."""
        return self.terrain.ramp_end_x_m

    # ---- views: Meshcat and RGB frames ---------------------------------------------------------
    @property
    def is_visualized(self) -> bool:
        """Whether the twin was built with a Meshcat (live view, recording)."""
        return self.visualizer is not None

    def publish(self) -> None:
        """Send the current pose to Meshcat now (no-op without a Meshcat)."""
        if self.visualizer is not None:
            self._sync_ground()
            self.visualizer.ForcedPublish(self.visualizer.GetMyContextFromRoot(self.context))

    def start_recording(self) -> None:
        """Start a new Meshcat recording (a previous one is discarded)."""
        if self.visualizer is None:
            raise RuntimeError("start_recording: build the Twin with meshcat=... to record")
        self.visualizer.DeleteRecording()
        self.visualizer.StartRecording(set_transforms_while_recording=True)

    def stop_recording(self) -> None:
        """Stop recording (the frames are kept for :meth:`save_recording`); no-op without a Meshcat."""
        if self.visualizer is not None:
            self.visualizer.StopRecording()

    def save_recording(self, path: str | Path) -> Path:
        """Stop recording and write a self-contained Meshcat HTML replay to ``path``."""
        if self.visualizer is None:
            raise RuntimeError("save_recording: build the Twin with meshcat=... to record")
        self.visualizer.StopRecording()
        self.visualizer.PublishRecording()
        return write_text_atomic(path, self.meshcat.StaticHtml())

    def render_rgb(self, width: int = 480, height: int = 360) -> np.ndarray:
        """An (height, width, 3) uint8 frame from Drake's RenderEngineVtk (EGL, headless), the
        camera following the robot from behind-left. The first call adds the render engine to
        this twin's SceneGraph context (and clears the hydroelastic shell cache, whose states
        would lack it)."""
        self._sync_ground()
        if self._camera is None:
            self._camera = RgbCamera(self.scene_graph, self.sg_context, width, height)
            self._shells.clear()
        return self._camera.render(self.state().position_m, width, height)
