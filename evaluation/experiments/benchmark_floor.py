"""The twin against Drake's floor: every setting timed on the same states, interleaved in one run.

Drake's floor is the robot URDF alone on the twin's ground (the ramp's and the run-out's
half-spaces, collision geometry only), with the twin's contact properties, stepped by a bare
``Simulator``: no force systems, no exported ports, no Python besides the loop. Its two forms:
Drake's default plant configuration (output ports sampled into the state at every step), and the
twin's (live output ports, ``sphere_env.physics.diagram``).

Pairing: a reference twin of each contact model (the full twin, zero torque) rolls 10 s down the
16° ramp in 20 ms chunks; before every chunk each case is set to the reference's positions and
velocities and advanced the same 20 ms (the cases in a rotating order, so no case always runs
first), and only that chunk is timed. Every case sees the same contacts and the same machine load,
so the ratios hold on a busy machine; the absolute chunks/s do not. A twin is stepped as the env
steps it (``Twin.advance_unchecked`` and ``Twin.state``), the floor by ``AdvanceTo`` and a read of
[q; v].
"""

from __future__ import annotations

import dataclasses
import os
import time
from typing import Callable

import numpy as np
from pydrake.geometry import AddContactMaterial, AddRigidHydroelasticProperties, ProximityProperties, RoleAssign
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlant, CoulombFriction, MultibodyPlantConfig
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from sphere_env.physics import Twin, TwinConfig
from sphere_env.physics.diagram import contact_approximation, ground_coefficient, shell_properties

CHUNK_S = 0.02
RAMP = dict(incline_deg=16.0, ramp_length_m=4.0)
ZERO = np.zeros(2)


class Floor:
    """The robot URDF on the twin's ground half-spaces, with ``twin``'s contact model, properties
    and time step; ``approximation`` the discrete contact solver (default: the twin's)."""

    def __init__(self, twin: Twin, approximation: str | None = None, sampled_outputs: bool = True):
        cfg = twin.config
        hydro = cfg.shell_model == "hydroelastic"
        builder = DiagramBuilder()
        plant, scene_graph = AddMultibodyPlant(
            MultibodyPlantConfig(
                time_step=cfg.time_step_s,
                discrete_contact_approximation=approximation or contact_approximation(cfg),
                contact_model="hydroelastic_with_fallback" if hydro else "point",
                use_sampled_output_ports=sampled_outputs,
            ),
            builder,
        )
        Parser(plant).AddModels(str(twin.robot.urdf_path))
        ground = ProximityProperties()
        mu_g = ground_coefficient(cfg.ground_friction)
        AddContactMaterial(friction=CoulombFriction(mu_g, mu_g), properties=ground)
        if hydro:
            AddRigidHydroelasticProperties(ground)
        for name, X_WG, shape, rgba in twin.terrain.geometries():
            if rgba is None:  # collision geometry only
                plant.RegisterCollisionGeometry(plant.world_body(), X_WG, shape, name, ground)
        (shell,) = plant.GetCollisionGeometriesForBody(plant.GetBodyByName("bedliner"))
        props = shell_properties(cfg, twin.shell, twin.pressure_kpa)
        scene_graph.AssignRole(plant.get_source_id(), shell, props, RoleAssign.kReplace)
        plant.Finalize()
        self.plant = plant
        self.simulator = Simulator(builder.Build())
        self.context = self.simulator.get_mutable_context()
        self.plant_context = plant.GetMyMutableContextFromRoot(self.context)
        plant.get_actuation_input_port().FixValue(self.plant_context, ZERO)
        self.simulator.Initialize()

    def step(self) -> None:
        self.simulator.AdvanceTo(self.context.get_time() + CHUNK_S)
        self.plant.GetPositionsAndVelocities(self.plant_context)


def _twin_step(twin: Twin) -> Callable[[], None]:
    def step() -> None:
        twin.advance_unchecked(CHUNK_S, ZERO)
        twin.state()

    return step


@dataclasses.dataclass
class Case:
    key: str
    label: str
    shell_model: str
    approximation: str
    plant: object
    plant_context: object
    step: Callable[[], None]
    wall_s: float = 0.0
    chunks: int = 0


def _twin_case(key: str, label: str, cfg: TwinConfig) -> Case:
    twin = Twin(cfg)
    approx = contact_approximation(cfg)
    return Case(key, label, cfg.shell_model, approx, twin.plant, twin.plant_context, _twin_step(twin))


def _floor_case(key: str, label: str, ref: Twin, approximation: str | None = None, sampled: bool = True) -> Case:
    f = Floor(ref, approximation, sampled)
    approx = approximation or contact_approximation(ref.config)
    return Case(key, label, ref.config.shell_model, approx, f.plant, f.plant_context, f.step)


def build_cases(shell_models: tuple[str, ...] = ("point", "hydroelastic")) -> tuple[dict[str, Twin], list[Case]]:
    """The reference twins (one per contact model) and the timed cases."""
    refs, cases = {}, []
    for m in shell_models:
        base = TwinConfig(shell_model=m, **RAMP)
        ref = refs[m] = Twin(base)
        solver = contact_approximation(base)
        cases += [
            _floor_case(f"{m}/floor", f"Drake's floor, {solver}, Drake's default config (sampled output ports)", ref),
            _floor_case(
                f"{m}/floor_live", f"Drake's floor, {solver}, live output ports (the twin's config)", ref, None, False
            ),
            _floor_case(f"{m}/floor_tamsi", "Drake's floor, tamsi, Drake's default config", ref, "tamsi"),
            _twin_case(
                f"{m}/bare",
                f"bare twin ({solver}; no friction or shell-law systems)",
                base.replace(bare_plant=True, steer_friction="none", drive_friction="none"),
            ),
            _twin_case(f"{m}/twin", f"full twin, {solver}", base),
            _twin_case(f"{m}/twin_tamsi", "full twin, tamsi", base.replace(contact_approximation="tamsi")),
        ]
        if m == "point":
            injected = base.replace(shell_model="injected")
            cases.append(_twin_case("injected/twin", "full twin, injected shell, sap", injected))
            cases.append(
                _twin_case(
                    "injected/twin_tamsi",
                    "full twin, injected shell, tamsi",
                    injected.replace(contact_approximation="tamsi"),
                )
            )
    return refs, cases


def run_paired(
    seconds: float = 10.0, repeats: int = 3, shell_models: tuple[str, ...] = ("point", "hydroelastic")
) -> dict:
    """Time every case on its reference trajectory (module docstring). Returns ``{"rows": [...],
    "load_avg_start", "load_avg_end", "seconds", "repeats"}``; each row has chunks/s and its ratio
    to the floor of its contact model (``ratio_floor``, default config) and to the live-port floor
    (``ratio_floor_live``)."""
    refs, cases = build_cases(shell_models)
    n = int(round(seconds / CHUNK_S))
    load0 = os.getloadavg()
    for _ in range(repeats):
        for ref in refs.values():
            ref.reset()
        for i in range(n):
            states = {m: r.plant.GetPositionsAndVelocities(r.plant_context) for m, r in refs.items()}
            k = i % len(cases)
            for c in cases[k:] + cases[:k]:
                x = states["point" if c.shell_model == "injected" else c.shell_model]
                c.plant.SetPositionsAndVelocities(c.plant_context, x)
                t0 = time.perf_counter()
                c.step()
                c.wall_s += time.perf_counter() - t0
                c.chunks += 1
            for ref in refs.values():
                ref.advance_unchecked(CHUNK_S, ZERO)
    load1 = os.getloadavg()
    rate = {c.key: c.chunks / c.wall_s for c in cases}
    rows = []
    for c in cases:
        contact = "point" if c.shell_model == "injected" else c.shell_model
        rows.append(
            dict(
                key=c.key,
                case=c.label,
                contact=contact,
                shell_model=c.shell_model,
                approximation=c.approximation,
                chunks=c.chunks,
                chunks_per_s=rate[c.key],
                rtf=rate[c.key] * CHUNK_S,
                ratio_floor=rate[c.key] / rate[f"{contact}/floor"],
                ratio_floor_live=rate[c.key] / rate[f"{contact}/floor_live"],
            )
        )
    return {"rows": rows, "load_avg_start": load0, "load_avg_end": load1, "seconds": seconds, "repeats": repeats}


#: The twin's aims against the floor and of hydroelastic against point contact.
AIM_FLOOR_RATIO = 0.9
AIM_HYDRO_OVER_POINT = 0.25


def summary(result: dict) -> dict:
    """The ratios the aims speak of, from :func:`run_paired`'s rows."""
    rate = {r["key"]: r["chunks_per_s"] for r in result["rows"]}
    out = {
        "twin_over_floor": rate["point/twin"] / rate["point/floor"],
        "twin_over_floor_live": rate["point/twin"] / rate["point/floor_live"],
        "bare_over_floor_live": rate["point/bare"] / rate["point/floor_live"],
        "tamsi_over_sap": {
            m: rate[f"{m}/twin_tamsi"] / rate[f"{m}/twin"]
            for m in ("point", "injected", "hydroelastic")
            if f"{m}/twin" in rate
        },
        "floor_tamsi_over_sap": rate["point/floor_tamsi"] / rate["point/floor"],
    }
    if "hydroelastic/twin" in rate:
        out["hydro_over_point"] = rate["hydroelastic/twin"] / rate["point/twin"]
        out["hydro_over_point_tamsi"] = rate["hydroelastic/twin_tamsi"] / rate["point/twin_tamsi"]
        out["hydro_floor_over_point_floor"] = rate["hydroelastic/floor"] / rate["point/floor"]
    return out


def floor_markdown(result: dict) -> str:
    from sphere_env.reporting import markdown_table

    s = summary(result)
    l0, l1 = result["load_avg_start"], result["load_avg_end"]
    cols = [
        ("contact", "contact", ""),
        ("case", "case", ""),
        ("chunks_per_s", "20 ms chunks/s", "{:.0f}"),
        ("rtf", "real-time factor", "{:.1f}x"),
        ("ratio_floor", "÷ floor (Drake's default config)", "{:.2f}"),
        ("ratio_floor_live", "÷ floor (live output ports)", "{:.2f}"),
    ]
    tamsi = ", ".join(f"{m} ×{v:.2f}" for m, v in s["tamsi_over_sap"].items())
    lines = [
        f"{result['seconds']:g} s of simulation per case and repeat, {result['repeats']} repeats, every case on the "
        f"states of its contact model's reference (injected on point contact's); 1-min load average {l0[0]:.1f} at "
        f"the start, {l1[0]:.1f} at the end: compare rows, not runs.",
        "",
        markdown_table(result["rows"], cols),
        "",
        f"- Full twin (point, sap) ÷ Drake's floor: **{s['twin_over_floor']:.2f}** against the floor in Drake's default "
        f"configuration, {s['twin_over_floor_live']:.2f} against the floor in the twin's configuration (live output "
        f"ports); the bare twin {s['bare_over_floor_live']:.2f} (aim ≥ {AIM_FLOOR_RATIO:g}).",
        f"- TAMSI ÷ SAP, full twin: {tamsi}; Drake's floor ×{s['floor_tamsi_over_sap']:.2f}.",
    ]
    if "hydro_over_point" in s:
        lines.append(
            f"- Hydroelastic ÷ point, full twin: **{s['hydro_over_point']:.2f}** with each model's default solver "
            f"(aim ≥ {AIM_HYDRO_OVER_POINT:g}), {s['hydro_over_point_tamsi']:.2f} with tamsi for both; Drake's floors "
            f"{s['hydro_floor_over_point_floor']:.2f}."
        )
    return "\n".join(lines)
