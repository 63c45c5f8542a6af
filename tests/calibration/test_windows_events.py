"""Log windows, free-motion events and the RoboBall channel mapping.

Synthetic logs are closed-form signals (a hold, then a damped swing); the real-data tests read
``../shared/data/roboball/free_robot`` and skip when it is absent.
"""

from pathlib import Path

import numpy as np
import pytest
import yaml

from sphere_env.analysis import damped_sinusoid
from sphere_env.calibration.__main__ import main
from sphere_env.calibration.events import find_events
from sphere_env.calibration.log_csv import load_log, write_log_csv
from sphere_env.calibration.logs import LogError
from sphere_env.calibration.manifest import load_manifest

from .conftest import write_manifest

FREE_ROBOT = "free_robot/data2-conv.csv"


def _release_log(path: Path, release_s: float = 2.0, push_s: float | None = 11.0, duration_s: float = 16.0) -> Path:
    """100 Hz: held at θ = 1.0 (φ = −0.4) until ``release_s``, then a damped swing to rest; optionally a
    push from rest at ``push_s`` (φ only); the drive joint never turns."""
    t = np.arange(0.0, duration_s, 0.01)
    theta, phi = np.full_like(t, 1.0), np.full_like(t, -0.4)
    after = t >= release_s
    tau = t[after] - release_s
    theta[after] = damped_sinusoid(tau, 1.05, 0.2, 3.6, 0.0, -0.05)
    phi[after] = damped_sinusoid(tau, -0.41, 0.2, 3.6, 0.0, 0.01)
    if push_s is not None:
        pushed = t >= push_s
        tau = t[pushed] - push_s
        phi[pushed] += 0.15 * np.exp(-0.2 * 3.6 * tau) * np.sin(3.5 * tau)
    rates = {"theta_dot": np.gradient(theta, t), "phi_dot": np.gradient(phi, t)}
    return write_log_csv(
        path,
        t,
        {"theta": theta, "phi": phi, "drive_angle": np.full_like(t, 13.9), "drive_rate": np.zeros_like(t), **rates},
    )


# ---- windows ---------------------------------------------------------------------------------------
def test_window_cuts_the_log_and_restarts_time(tmp_path):
    _release_log(tmp_path / "r.csv")
    man = write_manifest(
        tmp_path / "m.yaml",
        [
            {"name": "a", "file": "r.csv", "fixture": "free", "window_s": [2.0, 5.0]},
            {"name": "b", "file": "r.csv", "fixture": "free", "window_s": [11.0, 14.0]},  # same file twice
        ],
    )
    m = load_manifest(man)
    a, b = m.by_name("a").load(), m.by_name("b").load()
    assert a.fixture == "free" and a.window_s == (2.0, 5.0)
    assert a.t_s[0] == 0.0 and a.t_s[-1] == pytest.approx(3.0, abs=0.011) and a.t0_s == pytest.approx(2.0, abs=0.011)
    assert a["theta"][0] == pytest.approx(1.05 - 0.05, abs=0.01)  # the release sample
    assert b["theta"][0] == pytest.approx(-0.05, abs=0.01)  # long after the release, θ at rest


@pytest.mark.parametrize(
    "window, needle",
    [
        (
            [5.0, 2.0],
            "window_s' = (5.0, 2.0): low 5.0 is not below high 2.0; allowed: [start, end] in seconds from the "
            "log's first sample, 0 <= start < end",
        ),
        ([2.0, 2.0], "window_s' = (2.0, 2.0): low 2.0 is not below high 2.0; allowed: [start, end]"),
        (
            [-1.0, 2.0],
            "window_s[0]' = -1.0: Input should be greater than or equal to 0; allowed: [start, end] in seconds "
            "from the log's first sample, 0 <= start < end",
        ),
        ([1.0, float("nan")], "window_s[1]' = nan: not a finite number; allowed: [start, end]"),
        ([10.0, 20.0], "lies outside the log"),
        (["a", 2.0], "allowed: [start, end]"),
        ([1.0], "allowed: [start, end]"),
    ],
)
def test_bad_window_refused_by_name(tmp_path, window, needle):
    _release_log(tmp_path / "r.csv")
    man = write_manifest(tmp_path / "m.yaml", [{"name": "w", "file": "r.csv", "fixture": "free", "window_s": window}])
    with pytest.raises(LogError) as err:
        load_manifest(man).by_name("w").load()
    msg = str(err.value)
    assert "window_s" in msg and needle in msg, msg
    assert "m.yaml" in msg or "r.csv" in msg


def test_reversed_ramp_window_refused_by_name(tmp_path):
    man = write_manifest(
        tmp_path / "m.yaml", [{"name": "w", "file": "r.csv", "fixture": "free", "ramp_window_s": [3.0, 1.0]}]
    )
    with pytest.raises(LogError) as err:
        load_manifest(man)
    assert (
        "field 'trials[0].ramp_window_s' = (3.0, 1.0): low 3.0 is not below high 1.0; allowed: [start, end] "
        "seconds, start < end"
    ) in str(err.value)


def test_window_without_motion_refused(tmp_path):
    _release_log(tmp_path / "r.csv", push_s=None)
    man = write_manifest(
        tmp_path / "m.yaml", [{"name": "still", "file": "r.csv", "fixture": "free", "window_s": [0.0, 1.9]}]
    )
    with pytest.raises(LogError, match=r"r.csv.*'still'.*window_s.*no free motion to fit.*below 0.02 rad"):
        load_manifest(man).by_name("still").load()


def test_bad_window_makes_the_cli_exit_2_and_write_nothing(tmp_path):
    _release_log(tmp_path / "r.csv")
    man = write_manifest(
        tmp_path / "m.yaml", [{"name": "w", "file": "r.csv", "fixture": "free", "window_s": [3.0, 99.0]}]
    )
    out = tmp_path / "v.json"
    assert main(["validate", "--manifest", str(man), "--models", "point", "--json", str(out)]) == 2
    assert not out.exists()


# ---- events ----------------------------------------------------------------------------------------
def test_events_find_release_and_push_on_a_synthetic_log(tmp_path):
    log = load_log(_release_log(tmp_path / "r.csv"))
    ev = find_events(log)
    assert [e.kind for e in ev] == ["release", "push"]
    assert ev[0].start_s == pytest.approx(2.0, abs=0.02) and 3.0 < ev[0].duration_s < 7.0
    assert set(ev[0].moved) == {"theta", "phi"}  # the drive joint did not turn
    assert ev[1].start_s == pytest.approx(11.0, abs=0.02) and set(ev[1].moved) == {"phi"}
    # Both are free from their first turning point: the release's θ = A e^{−στ} cos(ω_d τ) turns at
    # ω_d τ = π − atan(σ / ω_d) (σ = 0.2 · 3.6, ω_d = 3.6 √(1 − 0.2²)); the push's φ ∝ e^{−στ} sin(3.5 τ)
    # at tan(3.5 τ) = 3.5 / σ.
    wd = 3.6 * np.sqrt(1 - 0.2**2)
    assert ev[0].free_start_s == pytest.approx(2.0 + (np.pi - np.arctan(0.72 / wd)) / wd, abs=0.02)
    assert ev[1].free_start_s == pytest.approx(11.0 + np.arctan(3.5 / 0.72) / 3.5, abs=0.02)


def test_driven_motion_and_monotonic_ramps_are_not_events(tmp_path):
    t = np.arange(0.0, 10.0, 0.01)
    ramp = np.clip(t - 2.0, 0.0, 1.0)  # a commanded steer ramp: one way, no swing
    p = write_log_csv(tmp_path / "ramp.csv", t, {"theta": ramp, "theta_dot": np.gradient(ramp, t)})
    assert find_events(load_log(p)) == []
    # The same swing as a release, but with the drive joint turning: driven, not free.
    swing = np.where(t > 2.0, damped_sinusoid(np.clip(t - 2.0, 0, None), 0.5, 0.2, 3.6, 0.0, 0.0), 0.5)
    p = write_log_csv(
        tmp_path / "driven.csv",
        t,
        {"phi": swing, "phi_dot": np.gradient(swing, t), "drive_angle": 0.3 * t, "drive_rate": np.full_like(t, 0.3)},
    )
    assert find_events(load_log(p)) == []
    out = tmp_path / "none.yaml"
    assert main(["events", str(p), "--write-manifest", str(out)]) == 1 and not out.exists()


def test_events_command_writes_loadable_manifest_atomically(tmp_path):
    p = _release_log(tmp_path / "r.csv")
    man = tmp_path / "events.yaml"
    assert main(["events", str(p), "--write-manifest", str(man), "--duration-s", "3", "--group", "g"]) == 0
    m = load_manifest(man)
    assert [s.fixture for s in m.trials] == ["free", "free"] and {s.group for s in m.trials} == {"g"}
    first = m.trials[0]
    assert first.window_s[0] == pytest.approx(2.83, abs=0.02) and first.window_s[1] - first.window_s[
        0
    ] == pytest.approx(3.0)
    assert first.load().t_s[-1] == pytest.approx(3.0, abs=0.011)
    assert m.trials[1].window_s[0] == pytest.approx(11.39, abs=0.02)  # both windows start free
    before = man.read_text()
    assert main(["events", str(p), "--write-manifest", str(man)]) == 2  # names already there: refused
    assert man.read_text() == before and [f.name for f in tmp_path.iterdir() if f.suffix == ".tmp"] == []


# ---- the real free_robot log -----------------------------------------------------------------------
@pytest.fixture(scope="module")
def free_robot(roboball_dir):
    return load_log(roboball_dir / FREE_ROBOT)


@pytest.mark.realdata
def test_free_robot_timestamps_are_nanoseconds_at_100_hz(free_robot):
    assert free_robot.t_s[-1] == pytest.approx(46.6, abs=0.1)  # README: 47 s
    assert np.median(np.diff(free_robot.t_s)) == pytest.approx(0.01, rel=0.05)  # README: 100 Hz


@pytest.mark.realdata
def test_free_robot_channel_mapping(free_robot):
    t, q, alpha = free_robot.t_s, free_robot["drive_angle"], free_robot["pendulum_pitch"]
    # drive_shaft (drive joint, motor encoder, negated into the twin's q_d) accumulates while
    # driving: ≈ 4.7 rad in the first drive ...
    drive = (t > 6.8) & (t < 17.7)
    assert q[t < 3.0].mean() - q[drive].min() == pytest.approx(4.74, abs=0.1)
    # ... and keeps a net turn afterwards: the encoder counts shell against pendulum.
    assert q[t < 3].mean() - q[t > 40].mean() == pytest.approx(0.86, abs=0.05)
    # pitch_joint (pendulum pitch against gravity) swings while driving and returns to a small
    # negative rest value (−0.076 before, −0.017 after): it does not accumulate.
    assert alpha[drive].min() < -0.4
    for rest in (alpha[t < 3.0], alpha[t > 40.0]):
        assert -0.1 < rest.mean() < 0.0 and np.ptp(rest) < 0.01
    # The rates are the positions' derivatives (a mapped-to-the-wrong-channel rate would not be).
    for ang, rate in (("drive_angle", "drive_rate"), ("pendulum_pitch", "pendulum_pitch_rate")):
        g = np.gradient(free_robot[ang], t)
        assert np.corrcoef(g, free_robot[rate])[0, 1] > 0.6
    # ω_d is derived (no raw channel) and flagged as such.
    assert free_robot.derived == {"omega_d": "pendulum_pitch_rate - drive_rate"}
    # The signs of ω_d = α̇ − q̇_d: while driving the pendulum leans ahead, so α and the twin's q̇_d
    # share their sign (forward: α < 0, q̇_d < 0, ω_d > 0), as in the twin.
    moving = np.abs(free_robot["drive_rate"]) > 0.2
    assert np.mean(np.sign(alpha[moving]) == np.sign(free_robot["drive_rate"][moving])) > 0.85


@pytest.mark.realdata
def test_free_robot_events_include_the_release(free_robot):
    ev = find_events(free_robot)
    rel = [e for e in ev if 32.5 < e.start_s < 33.1]
    assert len(rel) == 1 and rel[0].kind == "release"
    assert rel[0].start_s == pytest.approx(32.81, abs=0.02)  # the last held sample
    # free from θ's first turning point (θ̇ changes sign near θ ≈ −0.25 rad, 0.65 s after the hold)
    k = np.argmin(np.abs(free_robot.t_s + free_robot.t0_s - rel[0].free_start_s))
    assert rel[0].free_start_s == pytest.approx(33.46, abs=0.03)
    assert free_robot["theta"][k] == pytest.approx(-0.25, abs=0.01)
    assert free_robot["theta_dot"][k - 3] < 0 < free_robot["theta_dot"][k + 3]
    assert rel[0].duration_s == pytest.approx(4.4, abs=0.3)  # README: ≈ 4.4 s of free rocking
    assert {"theta", "phi"} <= set(rel[0].moved) and "drive_angle" not in rel[0].moved
    # The operator's driving (6.8–30.2 s) and the steer ramp (3.4–6 s) are not free motion.
    assert all(not (3.0 < e.start_s < 30.5) for e in ev)


@pytest.mark.realdata
def test_manifest_free_release_entry(roboball_dir):
    m = load_manifest(Path(__file__).resolve().parents[2] / "assets" / "logs" / "roboball.yaml", data_root=roboball_dir)
    spec = m.by_name("free_release")
    assert spec.group == "free_robot" and spec.fixture == "free"
    log = spec.load()
    rel = next(e for e in find_events(load_log(roboball_dir / "free_robot" / "data2-conv.csv")) if e.kind == "release")
    assert spec.window_s == (round(rel.free_start_s, 2), round(rel.end_s, 2))  # as for the pushes
    assert log["theta"][0] == pytest.approx(-0.248, abs=0.005) and log["phi"][0] == pytest.approx(-0.10, abs=0.01)
    assert abs(log["theta_dot"][0]) < 0.1  # the window starts at θ's first turning point
    yaml.safe_dump(log.meta)  # plain data


# ---- the three pushes of free_robot/pushes_20s-37s.csv -------------------------------------------
PUSHES = "free_robot/pushes_20s-37s.csv"


@pytest.mark.realdata
def test_pushes_log_has_three_pushes_two_one_way_one_the_other(roboball_dir):
    log = load_log(roboball_dir / PUSHES)
    ev = find_events(log)
    assert [e.kind for e in ev] == ["push", "push", "push"], [e.as_dict() for e in ev]
    # README: pushes around 2.3, 7.8 and 12.9 s, free rocking from about 2.7, 8.2 and 13.6 s.
    for e, start, free in zip(ev, (2.3, 7.8, 12.9), (2.7, 8.2, 13.6)):
        assert e.start_s == pytest.approx(start, abs=0.2)
        assert free - 0.1 < e.free_start_s < free + 0.4  # at or after the hand surely let go
        assert e.duration_s > 3.0 and "drive_angle" not in e.moved
    # Direction: the sign of φ's largest excursion from its value at the push's start, before the
    # robot is free; amplitude: φ there (README: to about −0.15, −0.21 and +0.37 rad).
    swing, peak = [], []
    for e in ev:
        k = (log.t_s >= e.start_s) & (log.t_s <= e.free_start_s)
        d = log["phi"][k] - log["phi"][k][0]
        swing.append(float(d[np.argmax(np.abs(d))]))
        peak.append(float(log["phi"][k][np.argmax(np.abs(d))]))
    assert swing[0] < 0 and swing[1] < 0 and swing[2] > 0, swing
    assert peak == pytest.approx([-0.15, -0.21, 0.37], abs=0.02)
    assert abs(peak[2]) > 1.5 * max(abs(peak[0]), abs(peak[1]))  # the third at about twice the amplitude


@pytest.mark.realdata
def test_manifest_push_windows_start_where_events_say_the_robot_is_free(roboball_dir):
    ev = find_events(load_log(roboball_dir / PUSHES))
    m = load_manifest(Path(__file__).resolve().parents[2] / "assets" / "logs" / "roboball.yaml", data_root=roboball_dir)
    specs = [m.by_name(f"push_{i}") for i in (1, 2, 3)]
    assert {s.name for s in m.group("free_robot")} == {"free_release", "push_1", "push_2", "push_3"}
    for spec, e in zip(specs, ev):
        assert spec.group == "free_robot" and spec.fixture == "free" and spec.file.name == Path(PUSHES).name
        assert spec.window_s == (round(e.free_start_s, 2), round(e.end_s, 2))
        assert spec.load(required=("phi", "theta")).t_s[-1] > 2.0
