"""Where a 20 ms chunk goes: Linux ``perf`` samples of a stepping loop, sorted into the pieces of
a step.

The loop runs in this process (:func:`profile_loop`): ``perf record`` samples it at
:data:`FREQUENCY_HZ` with DWARF call stacks, ``perf script`` prints the stacks, and each sample
goes to the first piece in :data:`PIECES` one of whose patterns names a frame of its stack (a
sample of the shell law evaluated inside the free-motion dynamics counts as the shell law).
Samples outside ``Simulator::AdvanceTo`` with Python frames are the Python side: the loop,
``Twin.state()``, the input port and the bindings; samples whose stack perf could not unwind
(a leaf frame it prints as ``[unknown]``, or no known frame) are counted apart. Without ``perf`` (Debian package ``linux-perf``) the profile is
skipped and says so.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import tempfile
import time
from collections import Counter
from pathlib import Path
from typing import Callable, Iterator

FREQUENCY_HZ = 299
ADVANCE = "Simulator<double>::AdvanceTo"
#: (key, label, frame name patterns), matched in this order.
PIECES = (
    (
        "force_systems",
        "friction and shell-law systems (SymbolicVectorSystem, C++)",
        ("SymbolicVectorSystem", "drake::symbolic::"),
    ),
    (
        "geometry",
        "geometry queries (SceneGraph poses, penetrations, contact surfaces)",
        ("drake::geometry::", "GeometryContactData", "fcl::"),
    ),
    ("contact_solve", "contact solve (SAP / TAMSI iterations)", ("SapSolver<", "TamsiSolver<")),
    (
        "free_motion",
        "free-motion dynamics (mass matrix, bias and applied forces)",
        ("CalcFreeMotionVelocities", "AccelerationsDueToNonConstraintForces", "CalcMassMatrix"),
    ),
    (
        "contact_setup",
        "contact problem setup (contact pairs, Jacobians, constraints)",
        ("SapDriver<", "TamsiDriver<", "DiscreteContactPairs", "CompliantContactManager<"),
    ),
    (
        "sampled_outputs",
        "sampled output ports (reaction forces, contact results)",
        ("CalcReactionForces", "CalcContactResults", "CalcGeneralizedContactForces"),
    ),
    (
        "plant_other",
        "rest of the plant step (state update, kinematics)",
        ("MultibodyPlant<", "MultibodyTree<", "DiscreteUpdateManager<"),
    ),
    (
        "simulator",
        "simulator and framework (events, state copy, cache invalidation)",
        (ADVANCE,),
    ),
)
PYTHON = ("python", "Python side: the loop, Twin.state(), the input port, bindings (outside AdvanceTo)")
#: Samples whose stack did not unwind to a known frame (perf prints ``[unknown]``).
UNRESOLVED = ("unresolved", "stack not unwound (unknown frames)")
UNKNOWN = "[unknown]"
PY_FRAME = "_PyEval_EvalFrame"
#: Inside the contact solve: SAP allocates a fresh solver context for every solve.
SAP_CONTEXT = "SapModel<double>::MakeContext"


def perf_available() -> bool:
    return shutil.which("perf") is not None


def _stacks(text: str) -> Iterator[list[str]]:
    """The stacks of ``perf script -F comm,ip,sym`` output, leaf first, as symbol names."""
    frames: list[str] = []
    for line in text.splitlines():
        if not line.strip():
            if frames:
                yield frames
            frames = []
        elif line[:1].isspace():
            parts = line.split(None, 1)
            if len(parts) == 2:
                frames.append(parts[1])
    if frames:
        yield frames


def sort_samples(text: str) -> dict:
    """Shares [%] of the pieces (:data:`PIECES`, then the Python side) in ``perf script`` output;
    ``sap_context_pct``: the share in SAP's per-solve context allocation (inside the solve)."""
    counts: Counter = Counter()
    sap_context = n = 0
    for frames in _stacks(text):
        n += 1
        sap_context += any(SAP_CONTEXT in f for f in frames)
        if not any(ADVANCE in f for f in frames) and any(PY_FRAME in f for f in frames) and frames[0] != UNKNOWN:
            counts[PYTHON[0]] += 1
            continue
        key = next((k for k, _, patterns in PIECES if any(p in f for f in frames for p in patterns)), UNRESOLVED[0])
        counts[key] += 1
    if n == 0:
        return {"samples": 0}
    keys = [k for k, _, _ in PIECES] + [PYTHON[0], UNRESOLVED[0]]
    return {"samples": n, "pct": {k: 100.0 * counts[k] / n for k in keys}, "sap_context_pct": 100.0 * sap_context / n}


def labels() -> dict[str, str]:
    return {k: label for k, label, _ in PIECES} | dict([PYTHON, UNRESOLVED])


def profile_loop(step: Callable[[], None], reset: Callable[[], None], seconds: float, chunks_per_reset: int = 500):
    """Sample ``step`` called in a loop for ``seconds`` (``reset`` every ``chunks_per_reset``
    calls). Returns :func:`sort_samples`' result with ``chunks`` and ``wall_s`` (perf's overhead
    included), or ``None`` when ``perf`` is missing or fails."""
    if not perf_available():
        return None
    with tempfile.TemporaryDirectory() as tmp:
        data = Path(tmp) / "perf.data"
        cmd = ["perf", "record", "-F", str(FREQUENCY_HZ), "--call-graph", "dwarf,32768", "-p", str(os.getpid())]
        rec = subprocess.Popen([*cmd, "-o", str(data)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(1.0)  # perf attaches
        chunks, t0 = 0, time.perf_counter()
        while time.perf_counter() - t0 < seconds:
            reset()
            for _ in range(chunks_per_reset):
                step()
            chunks += chunks_per_reset
        wall = time.perf_counter() - t0
        rec.send_signal(signal.SIGINT)
        try:
            rec.wait(timeout=120)
        except subprocess.TimeoutExpired:
            rec.kill()
            return None
        if rec.returncode not in (0, -signal.SIGINT) or not data.exists():
            return None
        script = subprocess.run(
            ["perf", "script", "--no-inline", "-F", "comm,ip,sym", "-i", str(data)],
            capture_output=True,
            text=True,
            timeout=900,
        )
    out = sort_samples(script.stdout)
    if not out["samples"]:
        return None
    return out | {"chunks": chunks, "wall_s": wall}


#: The profiled cases: (key, label, shell model, contact approximation or None, floor).
CASES = (
    ("floor_point", "Drake's floor, point, sap (default config)", "point", None, True),
    ("twin_point", "full twin, point, sap", "point", None, False),
    ("twin_injected", "full twin, injected, sap", "injected", None, False),
    ("twin_point_tamsi", "full twin, point, tamsi", "point", "tamsi", False),
    ("twin_hydroelastic", "full twin, hydroelastic, lagged", "hydroelastic", None, False),
)


def profile_cases(seconds: float = 8.0) -> dict:
    """Profile each of :data:`CASES` rolling down the benchmark's ramp from rest (its own
    trajectory, restarted every 10 s of simulation) for ``seconds`` of wall time. Returns
    ``{"available": bool, "cases": {key: {...}}, "labels": {...}}``."""
    import numpy as np

    from sphere_env.evaluation.experiments.benchmark_floor import CHUNK_S, RAMP, ZERO, Floor
    from sphere_env.physics import Twin, TwinConfig

    if not perf_available():
        return {"available": False, "cases": {}, "labels": labels()}
    out = {}
    for key, label, shell, approx, floor in CASES:
        twin = Twin(TwinConfig(shell_model=shell, contact_approximation=approx, **RAMP))
        if floor:
            f = Floor(twin)
            x0 = np.array(twin.plant.GetPositionsAndVelocities(twin.plant_context))

            def reset(f=f, x0=x0):
                f.context.SetTime(0.0)
                f.plant.SetPositionsAndVelocities(f.plant_context, x0)
                f.simulator.Initialize()

            step = f.step
        else:

            def step(twin=twin):
                twin.advance_unchecked(CHUNK_S, ZERO)
                twin.state()

            reset = twin.reset
        res = profile_loop(step, reset, seconds)
        if res is not None:
            out[key] = res | {"label": label}
    return {"available": bool(out), "cases": out, "labels": labels()}


def profile_markdown(profile: dict) -> str:
    """The shares of the pieces per profiled case, as a Markdown table."""
    from sphere_env.reporting import markdown_table

    if not profile.get("available"):
        return "Skipped: Linux `perf` not found (Debian package `linux-perf`) or it could not sample this process."
    cases = profile["cases"]
    rows = [
        {"piece": label} | {k: f"{c['pct'][key]:.1f}" for k, c in cases.items()}
        for key, label in profile["labels"].items()
    ]
    rows.append(
        {"piece": "… of which SAP's per-solve context allocation (inside the contact solve)"}
        | {k: f"{c['sap_context_pct']:.1f}" for k, c in cases.items()}
    )
    rows.append({"piece": "samples"} | {k: str(c["samples"]) for k, c in cases.items()})
    cols = [("piece", "share of the chunk %", "")] + [(k, c["label"], "") for k, c in cases.items()]
    return markdown_table(rows, cols)
