"""The digital twin: the robot URDF in a Drake diagram with selectable friction and shell models.

Frames (Drake notation): W world, PC pitch center (floating root, origin at the sphere centre),
P pipe assembly (shell), G ground. x_PC is forward, y_PC the driveshaft, z_PC up at rest.
Sign conventions (see README "Conventions"):
  θ      steer joint angle [rad] (pendulum vs driveshaft), URDF joint ``steer`` (axis +x_PC)
  q_d    drive joint angle [rad], URDF joint ``drive`` (axis −y_PC); + drive torque rolls backward
  φ      pipe angle [rad]: asin(ŷ_PC · n_G), the driveshaft's tilt against the ground
  ω_d    drive velocity [rad/s]: ω_WP · ŷ_PC, + when the shell rolls toward +x_PC
  ψ      heading [rad]: yaw of the horizontal forward direction ŷ_PC × ẑ_W
"""

from __future__ import annotations

import logging
import math
from collections import OrderedDict
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from pydrake.geometry import (
    AddCompliantHydroelasticProperties,
    AddContactMaterial,
    AddRigidHydroelasticProperties,
    Box,
    HalfSpace,
    ProximityProperties,
    RoleAssign,
)
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import (
    AddMultibodyPlant,
    CoulombFriction,
    MultibodyPlantConfig,
)
from pydrake.multibody.math import SpatialVelocity
from pydrake.multibody.tree import FixedOffsetFrame, PlanarJoint
from pydrake.symbolic import Expression, Variable, if_then_else
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, Multiplexer, SymbolicVectorSystem

from sphere_env.checks import finite_number
from sphere_env.models.friction import resolve_friction
from sphere_env.models.rigid_body import DEFAULT_URDF, RobotParameters
from sphere_env.models.shell import ShellCalibration, check_shell_model
from sphere_env.physics.forces import (
    build_force_expressions,
    cross3,
    pipe_angle_expressions,
)

_log = logging.getLogger("sphere_env")

FIXTURES = ("free", "locked_steer", "steer_plane", "stand")
CONTACT_APPROXIMATIONS = ("sap", "lagged", "similar", "tamsi")
_DEFAULT_APPROX = {"point": "sap", "injected": "sap", "hydroelastic": "lagged"}


@dataclass(frozen=True)
class TwinConfig:
    """Everything that defines one twin. Frozen; validated on construction.

    :param fixture: ``free`` | ``locked_steer`` | ``steer_plane`` | ``stand`` (DESIGN.md §4).
    :param shell_model: ``point`` | ``injected`` | ``hydroelastic``.
    :param steer_friction: law name (Table I preset for this joint), preset name, mapping
        ``{law, params}`` or :class:`FrictionModel`.
    :param drive_friction: as ``steer_friction``, for the drive joint.
    :param pressure_kpa: initial gauge pressure [kPa]; ``None`` = the calibration's nominal.
    :param incline_deg: ground incline [deg], downhill along +x_W.
    :param ramp_length_m: if set, the incline is a ramp of this length [m] (starting at the origin)
        followed by a flat run-out; if ``None`` the incline is an infinite plane.
    :param time_step_s: plant time step [s] (see ``evaluation/results/timestep_study.md``).
    :param ground_friction: Coulomb friction coefficient of shell and ground [-].
    :param calibration: path of a shell calibration YAML (``None`` = shipped default).
    :param urdf: robot URDF path (``None`` = shipped model).
    :param resolution_hint_m: hydroelastic mesh resolution [m]; ``None`` = calibration's value.
    :param contact_approximation: Drake discrete contact approximation; ``None`` picks ``sap``
        for point/injected and ``lagged`` (honours Hunt–Crossley dissipation) for hydroelastic.
    :param bare_plant: build without the friction/injected-torque system: the benchmark's
        bare-Drake floor (no joint friction, no injected shell torques).
    """

    fixture: str = "free"
    shell_model: str = "injected"
    steer_friction: Any = "majd"
    drive_friction: Any = "majd"
    pressure_kpa: float | None = None
    incline_deg: float = 0.0
    ramp_length_m: float | None = None
    time_step_s: float = 0.005
    ground_friction: float = 1.0
    calibration: str | Path | None = None
    urdf: str | Path | None = None
    resolution_hint_m: float | None = None
    contact_approximation: str | None = None
    bare_plant: bool = False

    def __post_init__(self) -> None:
        if self.fixture not in FIXTURES:
            raise ValueError(f"fixture: unknown value {self.fixture!r}; allowed: {list(FIXTURES)}")
        check_shell_model(self.shell_model)
        inc = finite_number("incline_deg", self.incline_deg, "[0, 45) deg")
        if not 0.0 <= inc < 45.0:
            raise ValueError(f"incline_deg: value {self.incline_deg!r} outside allowed [0, 45) deg")
        if self.fixture in ("steer_plane", "stand") and inc != 0.0:
            raise ValueError(f"incline_deg: value {inc} not allowed for fixture {self.fixture!r}; allowed: 0")
        if self.ramp_length_m is not None and not finite_number("ramp_length_m", self.ramp_length_m) > 0:
            raise ValueError(f"ramp_length_m: value {self.ramp_length_m!r} must be > 0 m or None")
        dt = finite_number("time_step_s", self.time_step_s, "(0, 0.05] s")
        if not 0 < dt <= 0.05:
            raise ValueError(f"time_step_s: value {self.time_step_s!r} outside allowed (0, 0.05] s")
        mu = finite_number("ground_friction", self.ground_friction, "(0, 5]")
        if not 0 < mu <= 5:
            raise ValueError(f"ground_friction: value {self.ground_friction!r} outside allowed (0, 5]")
        if self.resolution_hint_m is not None and not finite_number("resolution_hint_m", self.resolution_hint_m) > 0:
            raise ValueError(f"resolution_hint_m: value {self.resolution_hint_m!r} must be > 0 m")
        if self.contact_approximation is not None and self.contact_approximation not in CONTACT_APPROXIMATIONS:
            raise ValueError(
                f"contact_approximation: unknown value {self.contact_approximation!r}; "
                f"allowed: {list(CONTACT_APPROXIMATIONS)}"
            )
        # Resolve friction early so bad names fail here, before anything is built.
        object.__setattr__(self, "steer_friction", resolve_friction(self.steer_friction, "steer"))
        object.__setattr__(self, "drive_friction", resolve_friction(self.drive_friction, "drive"))


@dataclass
class InitialState:
    """A full initial state. Angles in rad, rates in rad/s, positions in m, velocities in m/s.

    Orientation of the pitch center is R_W,PC = Rz(ψ) Ry(pitch) Rx(roll) (world-referenced);
    ``position_m`` is the sphere centre in W (``None``: resting on the ground at the origin).
    Fixtures use the parts they have: ``steer_plane`` uses roll, position (y, z) and their
    rates; ``stand`` only θ, θ̇.
    """

    theta: float = 0.0
    drive_angle: float = 0.0
    roll: float = 0.0
    pitch: float = 0.0
    heading: float = 0.0
    position_m: tuple[float, float, float] | None = None
    theta_dot: float = 0.0
    drive_rate: float = 0.0
    angular_velocity_W: tuple[float, float, float] = (0.0, 0.0, 0.0)
    velocity_W: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def validate(self) -> "InitialState":
        for name in ("theta", "drive_angle", "roll", "pitch", "heading", "theta_dot", "drive_rate"):
            finite_number(f"initial_state.{name}", getattr(self, name))
        for name in ("position_m", "angular_velocity_W", "velocity_W"):
            val = getattr(self, name)
            if val is None:
                continue
            arr = np.asarray(val, dtype=float)
            if arr.shape != (3,) or not np.all(np.isfinite(arr)):
                raise ValueError(f"initial_state.{name}: value {val!r} must be 3 finite numbers")
        return self


@dataclass(frozen=True)
class TwinState:
    """A plain snapshot of the robot state (no Drake objects). Names follow DESIGN.md §1."""

    time_s: float
    theta: float  # θ, steer joint angle [rad]
    theta_dot: float  # [rad/s]
    drive_angle: float  # drive joint angle [rad] (log channel pitch_joint)
    drive_rate: float  # [rad/s]
    phi: float  # φ, pipe angle against the ground [rad]
    phi_dot: float  # [rad/s]
    omega_d: float  # ω_d, drive velocity [rad/s]
    heading: float  # ψ [rad]
    heading_rate: float  # ψ̇ [rad/s]
    position_m: np.ndarray  # sphere centre in W [m]
    velocity_m_s: np.ndarray  # sphere centre velocity in W [m/s]
    gravity_in_pipe: np.ndarray  # unit gravity direction in the pipe frame (IMU-like) [-]
    pressure_kpa: float

    def as_dict(self) -> dict:
        return {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in self.__dict__.items()}


class Terrain:
    """Ground geometry: an inclined plane, or a ramp of finite length with a flat run-out."""

    def __init__(self, incline_deg: float, ramp_length_m: float | None):
        self.alpha = math.radians(incline_deg)
        self.ramp_length_m = ramp_length_m
        self.R_WG = RotationMatrix.MakeYRotation(self.alpha)  # x_G down the fall line
        self.n_ramp = self.R_WG.col(2)
        self.t_ramp = self.R_WG.col(0)
        self._n_ramp = tuple(float(c) for c in self.n_ramp)
        # x_W where the flat run-out starts (inf: the incline never ends)
        self._x_runout = math.inf if ramp_length_m is None or self.alpha == 0.0 else float(self.ramp_end_W[0])

    @property
    def ramp_end_W(self) -> np.ndarray | None:
        return None if self.ramp_length_m is None else self.t_ramp * self.ramp_length_m

    def normal_at(self, p_W):
        """Ground normal n_W under a point, as a 3-tuple (numeric or symbolic in p_W)."""
        if math.isinf(self._x_runout):
            return self._n_ramp
        if isinstance(p_W[0], (Expression, Variable)):  # symbolic state variables are Variables
            return tuple(if_then_else(p_W[0] < self._x_runout, nr, nz) for nr, nz in zip(self._n_ramp, (0.0, 0.0, 1.0)))
        return self._n_ramp if p_W[0] < self._x_runout else (0.0, 0.0, 1.0)

    def register(self, plant, props: ProximityProperties) -> None:
        world = plant.world_body()
        if self.ramp_length_m is None:
            X = RigidTransform(HalfSpace.MakePose(self.n_ramp, np.zeros(3)))
            plant.RegisterCollisionGeometry(world, X, HalfSpace(), "ground", props)
            plant.RegisterVisualGeometry(
                world, RigidTransform(self.R_WG, -0.05 * self.n_ramp), Box(30, 30, 0.1), "ground_vis",
                np.array([0.55, 0.5, 0.45, 1.0]),
            )
            return
        # Ramp + flat run-out = union of two half-spaces: the terrain height is the max of the two
        # planes, so each half-space lies below the other's surface where that one is active.
        # (Half-spaces are much cheaper than boxes for hydroelastic contact.)
        end = self.ramp_end_W
        plant.RegisterCollisionGeometry(world, RigidTransform(HalfSpace.MakePose(self.n_ramp, np.zeros(3))), HalfSpace(), "ramp", props)
        plant.RegisterCollisionGeometry(world, RigidTransform(end), HalfSpace(), "runout", props)
        L, thick, margin = self.ramp_length_m, 0.1, 2.0
        X_ramp = RigidTransform(self.R_WG, self.t_ramp * (L - margin) / 2 - self.n_ramp * thick / 2)
        plant.RegisterVisualGeometry(world, X_ramp, Box(L + margin, 6, thick), "ramp_vis", np.array([0.55, 0.5, 0.45, 1.0]))
        X_run = RigidTransform(end + np.array([15.0, 0.0, -thick / 2]))
        plant.RegisterVisualGeometry(world, X_run, Box(30, 6, thick), "runout_vis", np.array([0.45, 0.5, 0.55, 1.0]))


class Twin:
    """The robot in Drake, advanced in chunks like an environment would.

    >>> twin = Twin(TwinConfig(shell_model="injected", incline_deg=16))
    >>> twin.reset(InitialState())
    >>> twin.advance(0.02, motor_torque=(0.0, 0.0)); twin.state().omega_d
    """

    def __init__(self, config: TwinConfig | None = None, meshcat=None, **kwargs):
        config = replace(config, **kwargs) if config is not None and kwargs else (config or TwinConfig(**kwargs))
        self.config = config
        self.calibration = ShellCalibration.load(config.calibration)
        self.robot = RobotParameters.from_urdf(config.urdf or DEFAULT_URDF)
        self.shell = self.calibration.bind(self.robot)
        p0 = self.calibration.nominal_pressure_kpa if config.pressure_kpa is None else config.pressure_kpa
        self._pressure_kpa = self.calibration.check_pressure(p0, "pressure_kpa")
        self.terrain = Terrain(config.incline_deg, config.ramp_length_m)
        fitted = self.calibration.fitted_time_step_s
        if config.shell_model == "hydroelastic" and fitted is not None and not math.isclose(fitted, config.time_step_s):
            _log.warning(
                "time_step_s=%g s differs from the %g s at which the calibration's hydroelastic dissipation "
                "was fitted; Drake's numerical contact damping depends on the step, so the shell's damping "
                "ratio will differ (see evaluation/results/timestep_study.md). Refit k_d at this step.",
                config.time_step_s, fitted,
            )
        self.meshcat = meshcat
        self._build()

    # ---- building --------------------------------------------------------------------------------
    def _build(self) -> None:
        cfg = self.config
        hydro = cfg.shell_model == "hydroelastic"
        approx = cfg.contact_approximation or _DEFAULT_APPROX[cfg.shell_model]
        builder = DiagramBuilder()
        plant_config = MultibodyPlantConfig(
            time_step=cfg.time_step_s,
            discrete_contact_approximation=approx,
            contact_model="hydroelastic_with_fallback" if hydro else "point",
        )
        plant, scene_graph = AddMultibodyPlant(plant_config, builder)
        self.plant, self.scene_graph = plant, scene_graph
        (self.model_instance,) = Parser(plant).AddModels(str(self.robot.urdf_path))
        body = plant.GetBodyByName
        self.pc, self.pipe, self.pendulum = body("pitch_center"), body("pipe_assembly"), body("pendulum")
        world = plant.world_frame()

        if cfg.fixture == "stand":
            # Shell held by the stand: pitch center welded high above the floor (no contact).
            plant.WeldFrames(world, self.pc.body_frame(), RigidTransform([0.0, 0.0, 1.0]))
        elif cfg.fixture == "steer_plane":
            # Planar joint in the world y–z plane, rotating about world x: frame F has
            # x_F = y_W, y_F = z_W, z_F = x_W, so planar coords are (y_W, z_W, φ).
            R_WF = RotationMatrix(np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]))
            F = plant.AddFrame(
                FixedOffsetFrame("steer_plane_F", world, RigidTransform(R_WF))
            )
            M = plant.AddFrame(
                FixedOffsetFrame("steer_plane_M", self.pc.body_frame(), RigidTransform(R_WF))
            )
            self.planar = plant.AddJoint(PlanarJoint("steer_plane", F, M, damping=np.zeros(3)))

        # Contact geometry.
        ground_props = ProximityProperties()
        AddContactMaterial(friction=CoulombFriction(cfg.ground_friction, cfg.ground_friction), properties=ground_props)
        if hydro:
            AddRigidHydroelasticProperties(ground_props)
        if cfg.fixture != "stand":
            self.terrain.register(plant, ground_props)
        (self.shell_geometry,) = plant.GetCollisionGeometriesForBody(body("bedliner"))
        self.shell_source_id = plant.get_source_id()
        scene_graph.AssignRole(
            self.shell_source_id, self.shell_geometry, self._shell_properties(self._pressure_kpa), RoleAssign.kReplace
        )
        plant.Finalize()

        # Joint bookkeeping.
        self.steer, self.drive = plant.GetJointByName("steer"), plant.GetJointByName("drive")
        nq, nv = plant.num_positions(), plant.num_velocities()
        base = None
        if cfg.fixture in ("free", "locked_steer"):
            base, bq, bv = "quaternion", self.pc.floating_positions_start(), self.pc.floating_velocities_start_in_v()
        elif cfg.fixture == "steer_plane":
            base, bq, bv = "planar", self.planar.position_start(), self.planar.velocity_start()
        else:
            bq = bv = None
        self._layout = dict(
            nq=nq, nv=nv, base=base, base_q=bq, base_v=bv,
            steer_q=self.steer.position_start(), steer_v=self.steer.velocity_start(),
            drive_q=self.drive.position_start(), drive_v=self.drive.velocity_start(),
            steer_locked=cfg.fixture == "locked_steer",
            drive_locked=cfg.fixture in ("steer_plane", "stand"),
        )

        # Friction + injected shell forces, evaluated in C++. A bare plant (benchmark floor) leaves
        # the applied-generalized-force port unconnected, i.e. zero.
        self._gain_source = None
        if not cfg.bare_plant:
            x, g, out, kinematics = build_force_expressions(
                self._layout, cfg.steer_friction, cfg.drive_friction, cfg.shell_model in ("injected", "hydroelastic"),
                self.terrain.normal_at,
            )
            k = kinematics[0] if kinematics is not None else np.array([], dtype=object)
            forces = builder.AddNamedSystem(
                "shell_and_friction", SymbolicVectorSystem(input=np.concatenate([x, k, g]), output=out)
            )
            self._gain_source = builder.AddNamedSystem("gains", ConstantVectorSource(np.zeros(len(g))))
            mux = builder.AddSystem(Multiplexer([nq + nv, len(k), len(g)] if len(k) else [nq + nv, len(g)]))
            builder.Connect(plant.get_state_output_port(), mux.get_input_port(0))
            if len(k):  # stage 1: φ, φ̇, axis, ŷ, ω_d computed once per step
                kin = builder.AddNamedSystem("shell_kinematics", SymbolicVectorSystem(input=x, output=kinematics[1]))
                builder.Connect(plant.get_state_output_port(), kin.get_input_port())
                builder.Connect(kin.get_output_port(), mux.get_input_port(1))
            builder.Connect(self._gain_source.get_output_port(), mux.get_input_port(mux.num_input_ports() - 1))
            builder.Connect(mux.get_output_port(), forces.get_input_port())
            builder.Connect(forces.get_output_port(), plant.get_applied_generalized_force_input_port())

        # Motor torques [τ_steer, τ_drive] at the joints, N m.
        order = [plant.get_joint_actuator(i).joint().name() for i in plant.GetJointActuatorIndices()]
        if order != ["steer", "drive"]:
            raise RuntimeError(f"robot URDF: expected actuators on [steer, drive], found {order}")
        builder.ExportInput(plant.get_actuation_input_port(), "motor_torque")
        builder.ExportOutput(plant.get_state_output_port(), "state")

        if self.meshcat is not None:
            from pydrake.geometry import MeshcatVisualizer, MeshcatVisualizerParams, Role

            self.visualizer = MeshcatVisualizer.AddToBuilder(
                builder, scene_graph, self.meshcat, MeshcatVisualizerParams(role=Role.kIllustration)
            )
        else:
            self.visualizer = None

        self.diagram = builder.Build()
        self.simulator = Simulator(self.diagram)
        self.context = self.simulator.get_mutable_context()
        self.plant_context = plant.GetMyMutableContextFromRoot(self.context)
        self.sg_context = scene_graph.GetMyMutableContextFromRoot(self.context)
        self._gain_context = (
            None if self._gain_source is None else self._gain_source.GetMyMutableContextFromRoot(self.context)
        )
        self._motor_port = self.diagram.get_input_port(0)
        self._motor_port.FixValue(self.context, np.zeros(2))
        self._friction_scale = np.array([1.0, 1.0])
        self._ground_friction = float(self.config.ground_friction)
        self._geometry_cache: OrderedDict = OrderedDict()
        self._apply_pressure_to_context()
        self.reset()

    def _shell_properties(self, pressure_kpa: float) -> ProximityProperties:
        cfg, cal = self.config, self.calibration
        props = ProximityProperties()
        if cfg.shell_model == "hydroelastic":
            modulus, dissipation = self.shell.hydroelastic(pressure_kpa)
            AddContactMaterial(
                dissipation=dissipation,
                friction=CoulombFriction(cfg.ground_friction, cfg.ground_friction),
                properties=props,
            )
            hint = cfg.resolution_hint_m or cal.resolution_hint_m
            AddCompliantHydroelasticProperties(resolution_hint=hint, hydroelastic_modulus=modulus, properties=props)
        else:
            AddContactMaterial(friction=CoulombFriction(cfg.ground_friction, cfg.ground_friction), properties=props)
        return props

    # ---- pressure --------------------------------------------------------------------------------
    GEOMETRY_CACHE_SIZE = 24  # hydroelastic shells kept per twin, one per distinct pressure
    @property
    def pressure_kpa(self) -> float:
        return self._pressure_kpa

    def shell_parameters(self, pressure_kpa: float | None = None) -> dict:
        """The shell model's parameters at a pressure (current by default), with units in the keys."""
        p = self._pressure_kpa if pressure_kpa is None else pressure_kpa
        return self.shell.parameters(self.config.shell_model, p)

    def set_pressure(self, pressure_kpa: float) -> None:
        """Change the inflation pressure [kPa gauge] now; takes effect on the next step.

        ``injected`` reads new K_inject, C_inject from the context; ``hydroelastic`` replaces the
        shell's proximity properties (modulus, dissipation) in the SceneGraph context.
        """
        self._pressure_kpa = self.calibration.check_pressure(pressure_kpa, "pressure_kpa")
        self._apply_pressure_to_context()

    def set_calibration(self, calibration: ShellCalibration | str | Path, pressure_kpa: float | None = None) -> None:
        """Use another shell calibration from now on (no rebuild), at ``pressure_kpa`` [kPa] or the
        current pressure. Validated first: on error nothing changes."""
        cal = calibration if isinstance(calibration, ShellCalibration) else ShellCalibration.load(calibration)
        p = cal.check_pressure(self._pressure_kpa if pressure_kpa is None else pressure_kpa, "pressure_kpa")
        shell = cal.bind(self.robot)
        self.calibration, self.shell, self._pressure_kpa = cal, shell, p
        self._apply_pressure_to_context()

    def set_friction_scale(self, steer: float = 1.0, drive: float = 1.0) -> None:
        """Scale each joint's friction torque (domain randomization); 1 = nominal."""
        for name, val in (("steer", steer), ("drive", drive)):
            if not finite_number(f"{name}_friction_scale", val) >= 0:
                raise ValueError(f"{name}_friction_scale: value {val!r} must be >= 0")
        self._friction_scale = np.array([float(steer), float(drive)])
        self._apply_gains()

    def _apply_gains(self) -> None:
        if self._gain_source is None:  # bare plant
            return
        law = self.shell.law_gains(self.config.shell_model, self._pressure_kpa)
        self._gain_source.get_mutable_source_value(self._gain_context).SetFromVector(
            np.concatenate([law, self._friction_scale])
        )

    def _apply_pressure_to_context(self) -> None:
        """Push the current pressure into the context.

        injected: new K_inject, C_inject gains. hydroelastic: new shell proximity properties
        (modulus, dissipation) via ``AssignRole(kReplace)``. Drake re-meshes the compliant shell
        for that (≈80 ms at the shipped 0.05 m resolution), so the resulting GeometryState is
        cached per (modulus, dissipation, ground friction), LRU, and restored in ≈2 ms when they
        recur; results are bit-identical.
        """
        self._apply_gains()
        if self.config.shell_model != "hydroelastic":
            return
        idx = self._geometry_state_index()
        key = (*self.shell.hydroelastic(self._pressure_kpa), self._ground_friction)
        snap = self._geometry_cache.get(key)
        if snap is not None:
            self.sg_context.get_mutable_abstract_parameter(idx).SetFrom(snap)
            self._geometry_cache.move_to_end(key)
            return
        self.scene_graph.AssignRole(
            self.sg_context, self.shell_source_id, self.shell_geometry,
            self._shell_properties(self._pressure_kpa), RoleAssign.kReplace,
        )
        self._geometry_cache[key] = self.sg_context.get_abstract_parameter(idx).Clone()
        if len(self._geometry_cache) > self.GEOMETRY_CACHE_SIZE:
            self._geometry_cache.popitem(last=False)

    # ---- state -----------------------------------------------------------------------------------
    def reset(self, initial: InitialState | None = None, pressure_kpa: float | None = None) -> TwinState:
        """Reset time and state (the diagram is reused). Pressure is kept unless given."""
        initial = (initial or InitialState()).validate()
        if pressure_kpa is not None:
            self.calibration.check_pressure(pressure_kpa, "pressure_kpa")
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
            V = SpatialVelocity(np.asarray(initial.angular_velocity_W, float), np.asarray(initial.velocity_W, float))
            plant.SetFreeBodySpatialVelocity(pc, self.pc, V)
        elif lay["base"] == "planar":
            p = np.asarray(initial.position_m, float) if initial.position_m is not None else np.array([0.0, 0.0, R])
            self.planar.set_translation(pc, [p[1], p[2]])
            self.planar.set_rotation(pc, initial.roll)
            self.planar.set_translational_velocity(pc, [initial.velocity_W[1], initial.velocity_W[2]])
            self.planar.set_angular_velocity(pc, initial.angular_velocity_W[0])
        if pressure_kpa is not None:
            self.set_pressure(pressure_kpa)
        self._motor_port.FixValue(self.context, np.zeros(2))
        self.simulator.Initialize()
        return self.state()

    def lock_joints(self, steer: bool = False, drive: bool = False) -> None:
        """Lock joints at their current angle (a brake) until the next ``reset``."""
        for joint, flag in ((self.steer, steer), (self.drive, drive)):
            if flag:
                joint.set_angular_rate(self.plant_context, 0.0)
                joint.Lock(self.plant_context)

    def advance(self, duration_s: float, motor_torque=(0.0, 0.0)) -> None:
        """Hold motor torques [τ_steer, τ_drive] (N m at the joints) for ``duration_s`` seconds."""
        tau = np.asarray(motor_torque, dtype=float)
        if tau.shape != (2,) or not np.all(np.isfinite(tau)):
            raise ValueError(f"motor_torque: value {motor_torque!r} must be 2 finite numbers [N m]")
        self.advance_unchecked(duration_s, tau)

    def positions_velocities(self) -> tuple[np.ndarray, np.ndarray]:
        return self.plant.GetPositions(self.plant_context), self.plant.GetVelocities(self.plant_context)

    def state(self) -> TwinState:
        """Read θ, φ, ω_d, heading, pose and rates from the plant state (DESIGN.md §1 names).

        Plain float math on [q; v] (≈10 µs): R_WPC from the normalized base quaternion, φ and φ̇
        from :func:`pipe_angle_expressions` (the same definition the injected law uses),
        ω_d = ω_WPC·ŷ − q̇_d, ψ = atan2(−ŷ_x, ŷ_y), gravity in the pipe frame
        g_P = −(row z of R_WP)ᵀ with R_WP = R_WPC R_y(−q_d) (the drive axis is −y_PC).
        """
        lay = self._layout
        x = self.plant.GetPositionsAndVelocities(self.plant_context).tolist()
        nq = lay["nq"]
        q_d, qd_dot = x[lay["drive_q"]], x[nq + lay["drive_v"]]
        if lay["base"] == "quaternion":
            i, j = lay["base_q"], nq + lay["base_v"]
            qw, qx, qy, qz = x[i : i + 4]
            k = 2.0 / (qw * qw + qx * qx + qy * qy + qz * qz)
            y_W = (k * (qx * qy - qw * qz), 1.0 - k * (qx * qx + qz * qz), k * (qy * qz + qw * qx))
            row_z = (k * (qx * qz - qw * qy), k * (qy * qz + qw * qx), 1.0 - k * (qx * qx + qy * qy))
            p_W, w_W, v_W = x[i + 4 : i + 7], x[j : j + 3], x[j + 3 : j + 6]
        elif lay["base"] == "planar":  # coords (y_W, z_W, φ) about world x
            i, j = lay["base_q"], nq + lay["base_v"]
            c, sn = math.cos(x[i + 2]), math.sin(x[i + 2])
            y_W, row_z = (0.0, c, sn), (0.0, sn, c)
            p_W, w_W, v_W = (0.0, x[i], x[i + 1]), (x[j + 2], 0.0, 0.0), (0.0, x[j], x[j + 1])
        else:  # stand: pitch center welded 1 m above the origin
            y_W, row_z = (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
            p_W, w_W, v_W = (0.0, 0.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        phi, phi_dot, _ = pipe_angle_expressions(y_W, w_W, self.terrain.normal_at(p_W))
        y_dot = cross3(w_W, y_W)
        c, sn = math.cos(q_d), -math.sin(q_d)
        return TwinState(
            time_s=self.context.get_time(),
            theta=x[lay["steer_q"]],
            theta_dot=x[nq + lay["steer_v"]],
            drive_angle=q_d,
            drive_rate=qd_dot,
            phi=phi,
            phi_dot=phi_dot,
            omega_d=w_W[0] * y_W[0] + w_W[1] * y_W[1] + w_W[2] * y_W[2] - qd_dot,
            heading=math.atan2(-y_W[0], y_W[1]),
            heading_rate=(y_W[0] * y_dot[1] - y_W[1] * y_dot[0]) / max(y_W[0] ** 2 + y_W[1] ** 2, 1e-12),
            position_m=np.array(p_W),
            velocity_m_s=np.array(v_W),
            gravity_in_pipe=-np.array((row_z[0] * c - row_z[2] * sn, row_z[1], row_z[0] * sn + row_z[2] * c)),
            pressure_kpa=self._pressure_kpa,
        )

    # ---- recording -------------------------------------------------------------------------------
    def start_recording(self) -> None:
        if self.visualizer is None:
            raise RuntimeError("start_recording: build the Twin with meshcat=... to record")
        self.visualizer.StartRecording(set_transforms_while_recording=True)

    def save_recording(self, path: str | Path) -> Path:
        """Stop recording and write a self-contained Meshcat HTML replay to ``path``."""
        self.visualizer.StopRecording()
        self.visualizer.PublishRecording()
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(self.meshcat.StaticHtml())
        return path

    # ==== environment support (issue 3) — appended by the env helper ==============================
    # Fast state readout, payload, ground friction and an unchecked torque path used by
    # sphere_env.envs every control step. Nothing above this line depends on it.

    def advance_unchecked(self, duration_s: float, motor_torque: np.ndarray) -> None:
        """:meth:`advance` without input validation; ``motor_torque`` must be a finite float64 (2,)."""
        self._motor_port.FixValue(self.context, motor_torque)
        self.simulator.AdvanceTo(self.context.get_time() + duration_s)

    def set_payload(self, mass_kg: float = 0.0, offset_m=(0.0, 0.0, 0.0)) -> None:
        """Add a point-mass payload to the pendulum, at its nominal COM shifted by ``offset_m``
        (pendulum frame, m). ``mass_kg = 0`` restores the URDF inertia. Context parameters only:
        no rebuild; survives :meth:`reset`."""
        from pydrake.multibody.tree import SpatialInertia, UnitInertia

        m = finite_number("payload_mass_kg", mass_kg, "[0, 50] kg")
        if not 0.0 <= m <= 50.0:
            raise ValueError(f"payload_mass_kg: value {mass_kg!r} outside allowed [0, 50] kg")
        off = np.asarray(offset_m, dtype=float)
        if off.shape != (3,) or not np.all(np.isfinite(off)) or np.any(np.abs(off) > 0.3):
            raise ValueError(f"payload_com_offset_m: value {offset_m!r} must be 3 finite numbers within ±0.3 m")
        if not hasattr(self, "_pendulum_inertia"):
            self._pendulum_inertia = self.pendulum.default_spatial_inertia()
        M0 = self._pendulum_inertia
        M = SpatialInertia(M0.get_mass(), M0.get_com(), M0.get_unit_inertia())
        if m > 0.0:
            p = self._pendulum_inertia.get_com() + off
            M += SpatialInertia(m, p, UnitInertia.PointMass(p))
        self.pendulum.SetSpatialInertiaInBodyFrame(self.plant_context, M)

    def set_ground_friction(self, mu: float) -> None:
        """Set the effective shell–ground Coulomb friction [-] (static = dynamic) in the context.

        Drake combines the two geometries' coefficients as 2 μ_s μ_g / (μ_s + μ_g); the shell keeps
        ``config.ground_friction`` (it is rewritten by :meth:`set_pressure`), so the ground's value is
        solved for: μ_g = μ μ_s / (2 μ_s − μ). Allowed: 0 < μ < 2 μ_s.
        """
        mu_s = float(self.config.ground_friction)
        mu = finite_number("ground_friction", mu, f"(0, {2 * mu_s})")
        if not 0.0 < mu < 2.0 * mu_s:
            raise ValueError(f"ground_friction: value {mu!r} outside allowed (0, {2 * mu_s}) (shell μ = {mu_s})")
        mu_g = mu * mu_s / (2.0 * mu_s - mu)
        inspector = self.scene_graph.model_inspector()
        for gid in inspector.GetAllGeometryIds():
            if inspector.GetFrameId(gid) != inspector.world_frame_id():
                continue  # only ground geometries (welded to the world)
            if inspector.GetProximityProperties(gid) is None:
                continue
            props = ProximityProperties(inspector.GetProximityProperties(gid))
            props.UpdateProperty("material", "coulomb_friction", CoulombFriction(mu_g, mu_g))
            self.scene_graph.AssignRole(self.sg_context, self.shell_source_id, gid, props, RoleAssign.kReplace)
        self._ground_friction = mu

    # Hydroelastic pressure changes re-mesh the compliant shell (≈90 ms). The SceneGraph context's
    # GeometryState for a given pressure is cached and restored (≈2 ms, ≈1.8 MB each, LRU), then
    # the current ground friction re-applied if it differs — bit-identical to a fresh set_pressure.
    def _geometry_state_index(self) -> int:
        idx = self.__dict__.get("_geometry_index")
        if idx is None:
            for i in range(self.sg_context.num_abstract_parameters()):
                try:
                    self.sg_context.get_abstract_parameter(i).get_value()
                except RuntimeError as err:  # C++ type unknown to Python: the message names it
                    if "GeometryState" in str(err):
                        idx = i
                        break
            if idx is None:
                raise RuntimeError("SceneGraph context: GeometryState parameter not found")
            self._geometry_index = idx
        return idx

    def add_renderer(self, name: str, engine) -> None:
        """Add a render engine to this twin's SceneGraph context (no rebuild); clears the
        geometry cache (cached states would not contain the renderer)."""
        self.scene_graph.AddRenderer(self.sg_context, name, engine)
        self._geometry_cache.clear()
