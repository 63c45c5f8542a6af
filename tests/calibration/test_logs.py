"""Log loader, column mapping and manifest: good input converts to SI, bad input is refused by name."""

import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from sphere_env.calibration.__main__ import main
from sphere_env.calibration.log_csv import load_log, write_log_csv
from sphere_env.calibration.logs import ColumnMapping, LogError
from sphere_env.calibration.manifest import load_manifest


def _csv(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def test_roboball_names_ns_timestamps(tmp_path):
    t = np.arange(50) * 0.02
    p = write_log_csv(tmp_path / "a.csv", t, {"theta": 0.3 * np.cos(5 * t), "phi": -0.1 * t, "omega_d": t})
    log = load_log(p)
    assert np.allclose(log.t_s, t, atol=1e-9)
    assert set(log.channels) == {"theta", "phi", "omega_d"}
    assert np.allclose(log["theta"], 0.3 * np.cos(5 * t))


def test_pipe_roll_alias(tmp_path):
    p = _csv(tmp_path / "b.csv", "timestamp,pipe_roll.position\n0,0.1\n20000000,0.2\n40000000,0.3\n")
    log = load_log(p, required=("phi",))
    assert np.allclose(log["phi"], [0.1, 0.2, 0.3]) and np.allclose(log.t_s, [0, 0.02, 0.04])


def test_user_mapping_degrees_and_ms(tmp_path):
    m = tmp_path / "map.yaml"
    m.write_text(
        yaml.safe_dump(
            {
                "time": {"column": "t_ms", "unit": "ms"},
                "channels": {"theta": {"column": "pend", "unit": "deg"}, "omega_d": {"column": "wheel", "unit": "rpm"}},
            }
        )
    )
    p = _csv(tmp_path / "c.csv", "t_ms,pend,wheel\n100,90,60\n120,45,30\n140,0,0\n")
    log = load_log(p, m)
    assert np.allclose(log.t_s, [0, 0.02, 0.04])
    assert np.allclose(log["theta"], [np.pi / 2, np.pi / 4, 0])
    assert np.allclose(log["omega_d"], [2 * np.pi, np.pi, 0])


def test_isolated_nan_interpolated(tmp_path):
    p = _csv(tmp_path / "d.csv", "timestamp,roll_joint.position\n0,0.0\n20000000,\n40000000,0.2\n60000000,0.3\n")
    assert np.allclose(load_log(p)["theta"], [0, 0.1, 0.2, 0.3])


BAD = {
    "missing_column": ("timestamp,foo\n0,1\n20000000,2\n", ("theta",), "column for 'theta' missing"),
    "missing_time": ("time,roll_joint.position\n0,1\n1,2\n", (), "time column 'timestamp' missing"),
    "non_monotonic": ("timestamp,roll_joint.position\n0,0\n40000000,0\n20000000,0\n", (), "line 4, column 'timestamp'"),
    "duplicate_time": ("timestamp,roll_joint.position\n0,0\n20000000,0\n20000000,0\n", (), "duplicate time"),
    "nan_run": (
        "timestamp,roll_joint.position\n0,0\n1,\n2,\n3,\n4,0\n".replace("\n1,", "\n20000000,")
        .replace("\n2,", "\n40000000,")
        .replace("\n3,", "\n60000000,")
        .replace("\n4,", "\n80000000,"),
        (),
        "lines 3-5, column 'roll_joint.position': NaN run",
    ),
    "empty_file": ("", (), "file is empty"),
    "header_only": ("timestamp,roll_joint.position\n", (), "no data rows"),
    "degrees_as_radians": (
        "timestamp,roll_joint.position\n0,10\n20000000,200\n40000000,400\n",
        (),
        "line 3, column 'roll_joint.position': theta spans",
    ),
    "seconds_as_ns": ("timestamp,roll_joint.position\n0,0\n0.02,0\n0.04,0\n", (), "median sample period"),
    "not_a_number": ("timestamp,roll_joint.position\n0,0\n20000000,abc\n", (), "line 3, column 'roll_joint.position'"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_input_refused_with_named_error(tmp_path, case):
    text, required, needle = BAD[case]
    p = _csv(tmp_path / f"{case}.csv", text)
    with pytest.raises(LogError) as err:
        load_log(p, required=required)
    msg = str(err.value)
    assert str(p) in msg and needle in msg, msg


def test_bad_mapping_unit(tmp_path):
    m = tmp_path / "map.yaml"
    m.write_text(
        yaml.safe_dump(
            {"time": {"column": "t", "unit": "s"}, "channels": {"theta": {"column": "x", "unit": "furlong"}}}
        )
    )
    with pytest.raises(LogError, match=r"map.yaml.*channels.theta.unit.*furlong"):
        ColumnMapping.load(m)


def _manifest(tmp_path, trials, root="."):
    path = tmp_path / "manifest.yaml"
    path.write_text(yaml.safe_dump({"data_root": root, "trials": trials}))
    return path


def test_manifest_and_transient(tmp_path):
    t = np.arange(100) * 0.02
    write_log_csv(tmp_path / "x.csv", t, {"theta": np.sin(t)})
    man = load_manifest(
        _manifest(
            tmp_path,
            [
                {
                    "name": "x",
                    "file": "x.csv",
                    "fixture": "stand",
                    "group": "g",
                    "pressure_kpa": None,
                    "transient_s": 0.5,
                }
            ],
        )
    )
    log = man.group("g")[0].load()
    assert log.fixture == "stand" and log.pressure_kpa is None
    assert log.t_s[0] == 0 and np.isclose(log["theta"][0], np.sin(0.5))


@pytest.mark.parametrize(
    "entry, needle",
    [
        ({"file": "x.csv", "fixture": "table"}, "field 'trials[0].fixture' = 'table'"),
        ({"file": "x.csv", "fixture": "stand", "pressure_kpa": -3}, "field 'trials[0].pressure_kpa' = -3"),
        ({"fixture": "stand"}, "field 'trials[0].file' is missing"),
    ],
)
def test_bad_manifest(tmp_path, entry, needle):
    with pytest.raises(LogError, match=re.escape(needle)):
        load_manifest(_manifest(tmp_path, [entry]))


def test_cli_bad_log_writes_nothing(tmp_path, capsys):
    _csv(tmp_path / "bad.csv", "timestamp,roll_joint.position\n0,0\n0,0\n")
    man = _manifest(tmp_path, [{"name": "b", "file": "bad.csv", "fixture": "stand", "group": "stand_swing"}])
    out = tmp_path / "presets.yaml"
    code = main(["friction", "--manifest", str(man), "--starts", "1", "--preset-file", str(out)])
    assert code == 2 and not out.exists()
    assert "duplicate time" in capsys.readouterr().err


def test_shipped_example_mapping_and_manifest_load():
    repo = Path(__file__).resolve().parents[2]
    m = ColumnMapping.load(repo / "assets" / "logs" / "example_mapping.yaml")
    assert m.time == ("t_ms", "ms") and "theta" in m.required
    man = load_manifest(repo / "assets" / "logs" / "roboball.yaml")
    assert {t.group for t in man.trials} == {"stand_swing", "steer_free", "free_robot", "free_robot_driven"}
    assert {t.kind for t in man.trials if t.group == "free_robot_driven"} == {"driven"}
    assert man.data_root.name == "roboball" and man.data_root.parent.name == "data"


def test_report_without_logs_writes_nothing(tmp_path, capsys):
    out = tmp_path / "report"
    assert main(["report", "--data-root", str(tmp_path / "absent"), "--out", str(out)]) == 2
    assert not out.exists() and "not found" in capsys.readouterr().err


@pytest.mark.parametrize(
    "entry, needle",
    [
        ({"file": "x.csv", "fixture": "stand", "windw_s": [0, 1]}, "unknown field 'trials[0].windw_s'; allowed: ["),
        (
            {"file": "x.csv", "fixture": "stand", "pressure_kpa": "4.0"},
            "field 'trials[0].pressure_kpa' = '4.0': Input should be a valid number",
        ),
        ({"file": "x.csv", "fixture": "stand", "transient_s": True}, "field 'trials[0].transient_s' = True"),
        ({"file": 3, "fixture": "stand"}, "field 'trials[0].file' = 3: Input should be a valid string"),
        ({"file": "x.csv", "fixture": "stand", "time_unit": "fortnight"}, "field 'trials[0].time_unit' = 'fortnight'"),
    ],
)
def test_manifest_unknown_keys_and_wrong_types_are_refused_by_name(tmp_path, entry, needle):
    with pytest.raises(LogError, match=re.escape(needle)):
        load_manifest(_manifest(tmp_path, [entry]))


def test_manifest_unknown_top_level_key_is_refused(tmp_path):
    path = tmp_path / "m.yaml"
    path.write_text(yaml.safe_dump({"data_rot": ".", "trials": [{"file": "x.csv", "fixture": "stand"}]}))
    with pytest.raises(LogError, match=re.escape("unknown field 'data_rot'; allowed: ['data_root', 'trials']")):
        load_manifest(path)


@pytest.mark.parametrize("how", ["dotdot", "absolute", "symlink"])
def test_manifest_paths_outside_data_root_are_refused_without_reading(tmp_path, how):
    root = tmp_path / "data"
    root.mkdir()
    secret = tmp_path / "secret.csv"
    secret.write_text("TOP-SECRET-LINE,1\n")
    file = {"dotdot": "../secret.csv", "absolute": str(secret), "symlink": "link.csv"}[how]
    if how == "symlink":
        (root / "link.csv").symlink_to(secret)
    path = tmp_path / "m.yaml"
    path.write_text(yaml.safe_dump({"data_root": "data", "trials": [{"file": file, "fixture": "stand"}]}))
    with pytest.raises(LogError) as err:
        load_manifest(path)
    msg = str(err.value)
    assert "field 'file'" in msg and "outside data_root" in msg and "TOP-SECRET" not in msg


def test_manifest_path_inside_data_root_by_absolute_name_is_accepted(tmp_path):
    t = np.arange(100) * 0.02
    write_log_csv(tmp_path / "x.csv", t, {"theta": np.sin(t)})
    man = load_manifest(_manifest(tmp_path, [{"name": "x", "file": str(tmp_path / "x.csv"), "fixture": "stand"}]))
    assert man.by_name("x").load().t_s.size == 100
