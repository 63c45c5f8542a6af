"""Building the twin's Drake diagram: plant, contact geometry, force systems, ports.

One function, :func:`build_diagram`, returns the built pieces as a :class:`TwinDiagram`;
:class:`~sphere_env.physics.twin.Twin` owns and drives them.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any

import numpy as np
from pydrake.geometry import (
    AddCompliantHydroelasticProperties,
    AddContactMaterial,
    AddRigidHydroelasticProperties,
    MeshcatVisualizer,
    MeshcatVisualizerParams,
    ProximityProperties,
    Role,
    RoleAssign,
)
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import (
    AddMultibodyPlant,
    CoulombFriction,
    DiscreteContactApproximation,
    MultibodyPlantConfig,
)
from pydrake.multibody.tree import FixedOffsetFrame, PlanarJoint, SpatialInertia
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import PortSwitch, SymbolicVectorSystem

from sphere_env.models.rigid_body import RobotParameters
from sphere_env.models.shell import BoundShell
from sphere_env.params import SHELL_FRICTION
from sphere_env.physics.config import DEFAULT_CONTACT_APPROXIMATION, TwinConfig
from sphere_env.physics.forces import build_force_expressions
from sphere_env.physics.terrain import Terrain


@dataclass
class TwinDiagram:
    """The built diagram and the handles the twin needs (Drake objects)."""

    diagram: Any
    simulator: Any
    context: Any
    plant: Any
    scene_graph: Any
    plant_context: Any
    sg_context: Any
    model_instance: Any
    pc: Any  # pitch-center body (floating root)
    pipe: Any  # pipe-assembly body (shell)
    pendulum: Any
    planar: Any  # steer_plane fixture's planar joint, else None
    steer: Any
    drive: Any
    shell_geometry: Any
    shell_source_id: Any
    layout: dict  # state indices: nq, nv, base kind, base/steer/drive q and v starts, locks
    # The friction/shell-couple system, whose numeric parameter 0 holds the gains
    # (forces.GAIN_NAMES), and its context; None for a bare plant.
    forces: Any
    forces_context: Any
    motor_port: Any  # [τ_steer, τ_drive] N m
    visualizer: Any  # MeshcatVisualizer or None
    ground_ids: dict  # ground geometry name -> GeometryId (Terrain.geometries)
    # incline [deg] -> PortSwitch input index of its shell-kinematics system, and the PortSwitch;
    # empty / None unless the config has several inclines and a shell couple
    kinematics_ports: dict
    kinematics_switch: Any


def ground_coefficient(mu: float) -> float:
    """The ground geometry's μ_g giving an effective μ against the shell's μ_s = SHELL_FRICTION:
    Drake combines 2 μ_s μ_g / (μ_s + μ_g), so μ_g = μ μ_s / (2 μ_s − μ)."""
    return mu * SHELL_FRICTION / (2.0 * SHELL_FRICTION - mu)


def hydroelastic_resolution_hint_m(config: TwinConfig, shell: BoundShell, pressure_kpa: float) -> float:
    """The compliant shell's mesh resolution hint [m] at a pressure: ``config.resolution_hint_m``
    if set, else the calibration's (which may be coarser at low pressure, ``low_pressure_mesh``)."""
    return config.resolution_hint_m or shell.calibration.resolution_hint_at(pressure_kpa)


def shell_properties(config: TwinConfig, shell: BoundShell, pressure_kpa: float) -> ProximityProperties:
    """The shell's proximity properties at a pressure: friction μ_s and, for ``hydroelastic``, the
    compliant-hydroelastic modulus, Hunt–Crossley dissipation and mesh resolution (the config's
    ``resolution_hint_m`` if set, else the calibration's at this pressure) of the bound calibration."""
    cfg = config
    props = ProximityProperties()
    if cfg.shell_model == "hydroelastic":
        modulus, dissipation = shell.hydroelastic(pressure_kpa)
        AddContactMaterial(
            dissipation=dissipation,
            friction=CoulombFriction(SHELL_FRICTION, SHELL_FRICTION),
            properties=props,
        )
        hint = hydroelastic_resolution_hint_m(cfg, shell, pressure_kpa)
        AddCompliantHydroelasticProperties(resolution_hint=hint, hydroelastic_modulus=modulus, properties=props)
    else:
        AddContactMaterial(friction=CoulombFriction(SHELL_FRICTION, SHELL_FRICTION), properties=props)
    return props


_log = logging.getLogger(__name__)


def offered_contact_approximations() -> tuple[str, ...]:
    """The discrete contact approximations the installed Drake offers (``tamsi``, deprecated in
    Drake, may be gone from a later release)."""
    return tuple(name[1:].lower() for name in dir(DiscreteContactApproximation) if name.startswith("k"))


def contact_approximation(cfg: TwinConfig) -> str:
    """The approximation the plant is built with: the config's, or the shell model's default
    (:data:`DEFAULT_CONTACT_APPROXIMATION`). One the installed Drake no longer offers falls back to
    ``sap``, the reference physics, with a one-line warning naming the reason."""
    approx = cfg.contact_approximation or DEFAULT_CONTACT_APPROXIMATION[cfg.shell_model]
    offered = offered_contact_approximations()
    if approx not in offered:
        _log.warning(
            "contact_approximation=%r: not offered by the installed Drake (offers %s); using 'sap'",
            approx,
            ", ".join(offered),
        )
        return "sap"
    return approx


def _add_fixture(plant, fixture: str, pc):
    """Hold the pitch center as ``fixture`` has it: welded on the stand, on a planar joint in the
    steer plane, else free; the planar joint, or None."""
    world = plant.world_frame()
    if fixture == "stand":
        # Shell held by the stand: pitch center welded high above the floor (no contact).
        plant.WeldFrames(world, pc.body_frame(), RigidTransform([0.0, 0.0, 1.0]))
    elif fixture == "steer_plane":
        # Planar joint in the world y–z plane, rotating about world x: frame F has
        # x_F = y_W, y_F = z_W, z_F = x_W, so planar coords are (y_W, z_W, φ).
        R_WF = RotationMatrix(np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]))
        F = plant.AddFrame(FixedOffsetFrame("steer_plane_F", world, RigidTransform(R_WF)))
        M = plant.AddFrame(FixedOffsetFrame("steer_plane_M", pc.body_frame(), RigidTransform(R_WF)))
        return plant.AddJoint(PlanarJoint("steer_plane", F, M, damping=np.zeros(3)))
    return None


def _add_ground(plant, cfg: TwinConfig, terrain: Terrain) -> dict:
    """The ground's contact geometry (none on the stand), with the config's effective friction;
    the terrain's geometry ids."""
    ground_props = ProximityProperties()
    mu_g = ground_coefficient(cfg.ground_friction)
    AddContactMaterial(friction=CoulombFriction(mu_g, mu_g), properties=ground_props)
    if cfg.shell_model == "hydroelastic":
        AddRigidHydroelasticProperties(ground_props)
    if cfg.fixture == "stand":
        return {}
    ground = None  # the world body: anchored ground geometry
    if len(cfg.inclines_deg) > 1:
        # Anchored geometry cannot be moved in a context (SceneGraph.ChangeShape leaves the
        # world pose the contact queries use at its old value), geometry on a body welded to
        # the world can: its world pose is recomputed from its pose in the body at every update.
        ground = plant.AddRigidBody("ground", plant.AddModelInstance("ground"), SpatialInertia.Zero())
        plant.WeldFrames(plant.world_frame(), ground.body_frame())
    return terrain.register(plant, ground_props, ground)


def _joint_layout(plant, fixture: str, pc, planar, steer, drive) -> dict:
    """Where the base, steer and drive coordinates sit in the finalized plant's q and v, and which
    joints the fixture locks."""
    if fixture in ("free", "locked_steer"):
        base, bq, bv = "quaternion", pc.floating_positions_start(), pc.floating_velocities_start_in_v()
    elif fixture == "steer_plane":
        base, bq, bv = "planar", planar.position_start(), planar.velocity_start()
    else:
        base = bq = bv = None
    return dict(
        nq=plant.num_positions(),
        nv=plant.num_velocities(),
        base=base,
        base_q=bq,
        base_v=bv,
        steer_q=steer.position_start(),
        steer_v=steer.velocity_start(),
        drive_q=drive.position_start(),
        drive_v=drive.velocity_start(),
        steer_locked=fixture == "locked_steer",
        drive_locked=fixture in ("steer_plane", "stand"),
    )


def _add_forces(builder, plant, cfg: TwinConfig, terrain: Terrain, layout: dict) -> tuple[Any, Any, dict]:
    """Friction + injected shell forces, evaluated in C++, on the plant's applied generalized force
    port (a bare plant, the benchmark floor, leaves that port unconnected, i.e. zero): (the force
    system, the shell-kinematics switch of a twin with several inclines or None, its input port
    per incline)."""
    switch = None
    kinematics_ports: dict = {}
    x, g, out, kinematics = build_force_expressions(
        layout,
        cfg.steer_friction,
        cfg.drive_friction,
        cfg.shell_model in ("injected", "hydroelastic"),
        terrain.normal_at,
    )
    # The gains are the force system's numeric parameter (set in its context by the twin), so
    # the systems form a chain without a Multiplexer: each stage passes on the state entries
    # the forces read directly (the joint rates of the friction laws).
    used = {u.get_id() for e in out for u in e.GetVariables()}
    x_idx = [i for i, xi in enumerate(x) if xi.get_id() in used]
    k = kinematics[2] if kinematics is not None else np.array([], dtype=object)
    forces_input = np.concatenate([k, x[x_idx]]) if len(k) else x
    forces = builder.AddNamedSystem(
        "shell_and_friction", SymbolicVectorSystem(input=forces_input, parameter=g, output=out)
    )
    if len(k):
        # Stage 2: φ, φ̇ and the rocking axis from stage 1's projections (ŷ and ω_d pass on).
        p, p_exprs, _, k_exprs = kinematics
        angles = builder.AddNamedSystem(
            "shell_pipe_angle",
            SymbolicVectorSystem(input=np.concatenate([p, x[x_idx]]), output=np.concatenate([k_exprs, x[x_idx]])),
        )
        builder.Connect(angles.get_output_port(), forces.get_input_port())
    if len(k) and len(cfg.inclines_deg) > 1:
        # One stage-1 system per incline (the ground normal is a constant of the expressions,
        # exactly as for a single incline); a PortSwitch passes the current incline's on.
        # Only the selected input is evaluated.
        switch = builder.AddNamedSystem("shell_kinematics_switch", PortSwitch(len(p) + len(x_idx)))
        for inc in cfg.inclines_deg:
            if inc == cfg.incline_deg:
                x_i, p_exprs_i = x, p_exprs
            else:
                x_i, _, _, kin_i = build_force_expressions(
                    layout, cfg.steer_friction, cfg.drive_friction, True, Terrain(inc, cfg.ramp_length_m).normal_at
                )
                p_exprs_i = kin_i[1]
            kin = builder.AddNamedSystem(
                f"shell_kinematics_{inc:g}deg",
                SymbolicVectorSystem(input=x_i, output=np.concatenate([p_exprs_i, x_i[x_idx]])),
            )
            builder.Connect(plant.get_state_output_port(), kin.get_input_port())
            port = switch.DeclareInputPort(f"incline_{inc:g}deg")
            builder.Connect(kin.get_output_port(), port)
            kinematics_ports[inc] = port.get_index()
        builder.Connect(switch.get_output_port(), angles.get_input_port())
    elif len(k):  # stage 1: ŷ·n, ŷ×n, ẏ·n, ŷ, ω_d computed once per step
        kin = builder.AddNamedSystem(
            "shell_kinematics", SymbolicVectorSystem(input=x, output=np.concatenate([p_exprs, x[x_idx]]))
        )
        builder.Connect(plant.get_state_output_port(), kin.get_input_port())
        builder.Connect(kin.get_output_port(), angles.get_input_port())
    else:
        builder.Connect(plant.get_state_output_port(), forces.get_input_port())
    builder.Connect(forces.get_output_port(), plant.get_applied_generalized_force_input_port())
    return forces, switch, kinematics_ports


def build_diagram(
    config: TwinConfig, robot: RobotParameters, terrain: Terrain, shell_props: ProximityProperties, meshcat=None
) -> TwinDiagram:
    """Build plant + scene graph (+ friction/injected-shell systems, + Meshcat visualizer)."""
    cfg = config
    hydro = cfg.shell_model == "hydroelastic"
    builder = DiagramBuilder()
    plant_config = MultibodyPlantConfig(
        time_step=cfg.time_step_s,
        discrete_contact_approximation=contact_approximation(cfg),
        contact_model="hydroelastic_with_fallback" if hydro else "point",
        # Live output ports: Drake's default samples the dynamics outputs (contact results,
        # reaction forces) into the state at every step, which the twin never reads; the state
        # output is the same either way (evaluation/results/benchmark.md).
        use_sampled_output_ports=False,
    )
    plant, scene_graph = AddMultibodyPlant(plant_config, builder)
    (model_instance,) = Parser(plant).AddModels(str(robot.urdf_path))
    body = plant.GetBodyByName
    pc, pipe, pendulum = body("pitch_center"), body("pipe_assembly"), body("pendulum")
    planar = _add_fixture(plant, cfg.fixture, pc)
    ground_ids = _add_ground(plant, cfg, terrain)
    (shell_geometry,) = plant.GetCollisionGeometriesForBody(body("bedliner"))
    shell_source_id = plant.get_source_id()
    scene_graph.AssignRole(shell_source_id, shell_geometry, shell_props, RoleAssign.kReplace)
    plant.Finalize()
    steer, drive = plant.GetJointByName("steer"), plant.GetJointByName("drive")
    layout = _joint_layout(plant, cfg.fixture, pc, planar, steer, drive)
    forces, switch, kinematics_ports = (
        (None, None, {}) if cfg.bare_plant else _add_forces(builder, plant, cfg, terrain, layout)
    )

    # Motor torques [τ_steer, τ_drive] at the joints, N m.
    order = [plant.get_joint_actuator(i).joint().name() for i in plant.GetJointActuatorIndices()]
    if order != ["steer", "drive"]:
        raise RuntimeError(f"robot URDF: expected actuators on [steer, drive], found {order}")
    builder.ExportInput(plant.get_actuation_input_port(), "motor_torque_nm")
    builder.ExportOutput(plant.get_state_output_port(), "state")

    if meshcat is not None:
        visualizer = MeshcatVisualizer.AddToBuilder(
            builder, scene_graph, meshcat, MeshcatVisualizerParams(role=Role.kIllustration)
        )
    else:
        visualizer = None

    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    sg_context = scene_graph.GetMyMutableContextFromRoot(context)
    forces_context = None if forces is None else forces.GetMyMutableContextFromRoot(context)
    motor_port = diagram.get_input_port(0)
    return TwinDiagram(
        diagram=diagram,
        simulator=simulator,
        context=context,
        plant=plant,
        scene_graph=scene_graph,
        plant_context=plant_context,
        sg_context=sg_context,
        model_instance=model_instance,
        pc=pc,
        pipe=pipe,
        pendulum=pendulum,
        planar=planar,
        steer=steer,
        drive=drive,
        shell_geometry=shell_geometry,
        shell_source_id=shell_source_id,
        layout=layout,
        forces=forces,
        forces_context=forces_context,
        motor_port=motor_port,
        visualizer=visualizer,
        ground_ids=ground_ids,
        kinematics_ports=kinematics_ports,
        kinematics_switch=switch,
    )
