"""Bounded inputs: no YAML, value or log the project reads can exhaust memory or the stack, and no
error message echoes an input in full.

Every YAML goes through :mod:`sphere_env.safe_yaml` (size, depth, alias expansion, repeated keys);
every echoed value is cut (:func:`sphere_env.schemas.shown`). A refused input ends in one named
error line, with the process's peak memory under 1 GB."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest
import yaml

from sphere_env import safe_yaml
from sphere_env.schemas import Schema, shown, validate
from tests.conftest import TINY_PPO_PARAMS
from tests.hostile.test_interfaces import (  # noqa: F401 - fixtures
    TINY,
    _manifest,
    _refused,
    _write,
    inputs,
    out,
)


def _laughs(levels: int = 9, width: int = 9) -> str:
    """A YAML alias bomb as a flow sequence: ``width ** levels`` items once expanded, a few hundred bytes."""
    names = [f"l{i}" for i in range(levels + 1)]
    parts = [f"&{names[0]} [" + ", ".join(["x"] * width) + "]"]
    parts += [f"&{names[i]} [" + ", ".join([f"*{names[i - 1]}"] * width) + "]" for i in range(1, levels + 1)]
    return "[" + ", ".join(parts) + "]"


BOMB = _laughs()
DEEP = "[" * 5000 + "]" * 5000


@pytest.mark.parametrize(
    "text, problem",
    [
        (f"a: {BOMB}", "expands to more than"),
        (DEEP, "nested deeper than"),
        ("{" + "a: {" * 3000 + "}" * 3001, "nested deeper than"),
        ("a: &a [1, *a]", "contains it"),
        ("n_envs: 2\nn_envs: 4\n", "key 'n_envs' given twice"),
        ("x" * (safe_yaml.MAX_BYTES + 1), "bytes of YAML"),
    ],
    ids=["alias-bomb", "deep-list", "deep-mapping", "recursive-alias", "duplicate-key", "too-large"],
)
def test_the_yaml_loader_refuses_what_has_no_bound(text, problem):
    with pytest.raises(yaml.YAMLError, match=problem):
        safe_yaml.load(text)


def test_the_yaml_loader_reads_what_yaml_allows():
    text = "base: &b {k: 1, m: [1, 2]}\nmore: {<<: *b, k: 2}\nshared: [*b, *b]\n"
    assert safe_yaml.load(text) == {
        "base": {"k": 1, "m": [1, 2]},
        "more": {"k": 2, "m": [1, 2]},
        "shared": [{"k": 1, "m": [1, 2]}] * 2,
    }


def test_every_shipped_yaml_loads_within_the_bounds():
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    files = [
        p
        for folder in ("assets", "training", "evaluation")
        for p in (root / folder).rglob("*.y*ml")
        if p.suffix in (".yaml", ".yml")
    ]
    assert len(files) > 5
    for p in files:
        assert safe_yaml.load_file(p) == yaml.safe_load(p.read_text()), p


class _One(Schema):
    pressure_kpa: float = 1.0


@pytest.mark.parametrize(
    "value",
    ["x" * 10_000_000, list(range(1_000_000)), yaml.load(f"a: {_laughs(7, 9)}", yaml.SafeLoader)],
    ids=["long-string", "long-list", "shared-nesting"],
)
def test_an_error_message_echoes_a_bounded_value(value):
    with pytest.raises(ValueError) as err:
        validate(_One, {"pressure_kpa": value}, "input")
    message = str(err.value)
    assert "field 'pressure_kpa' = " in message and len(message) < 600, message[:1000]


def test_shown_cuts_and_marks_the_cut():
    assert shown("abc") == "'abc'"
    assert len(shown("x" * 10**6)) <= 200 and "..." in shown("x" * 10**6)


# ---- through the command lines, memory measured -----------------------------------------------------------
# The command's own peak: VmHWM of /proc/self/status, the high-water mark of the address space exec
# made. (ru_maxrss would carry over the forking test worker's peak, which Linux keeps across exec.)
PEAK = textwrap.dedent(
    """
    import sys
    from sphere_env.cli import main
    try:
        code = main(sys.argv[1:])
    except SystemExit as exc:
        code = exc.code
    hwm = next(line for line in open("/proc/self/status") if line.startswith("VmHWM:"))
    print("peak_mb", int(hwm.split()[1]) / 1024, file=sys.stderr)
    sys.exit(code)
    """
)


@pytest.mark.slow
@pytest.mark.parametrize(
    "argv, field",
    [
        (["train", "--env-kwargs", "{shell_model: " + BOMB + "}"], "env_kwargs"),
        (
            ["train", "--env-kwargs", "{observation_noise_scale: " + _laughs(5, 9) + "}"],
            "env_kwargs.observation_noise_scale",
        ),
        (["train", "--env-kwargs", DEEP], "env_kwargs"),
        (["train", "--env-kwargs", "shell_model:" + "[" * 5000 + "]" * 5000], "env_kwargs"),
    ],
    ids=["alias-bomb", "alias-bomb-within-bounds", "deep-yaml", "deep-literal"],
)
def test_a_refused_command_line_stays_under_1_gb(argv, field, tmp_path):
    cmd = [sys.executable, "-c", PEAK, *argv, *TINY, "--params", *TINY_PPO_PARAMS, "--run-dir", str(tmp_path / "run")]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    errors = [line for line in proc.stderr.splitlines() if "error:" in line]
    assert proc.returncode == 2, proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr and len(errors) == 1, proc.stderr[-3000:]
    assert field in errors[0] and len(errors[0]) < 1000, errors[0][:1000]
    peak = float(proc.stderr.split("peak_mb")[-1].split()[0])
    assert peak < 1024, f"peak {peak:.0f} MB"
    assert not (tmp_path / "run").exists()


@pytest.mark.slow
def test_a_hyperparameter_file_with_an_alias_bomb_is_refused_naming_it(tmp_path, out, capsys):  # noqa: F811 - the fixture
    conf = _write(tmp_path / "bomb.yml", f"sphere_env/RampDescent-v0:\n  env_kwargs:\n    notes: {BOMB}\n")
    _refused(
        ["train", *TINY, "-conf", str(conf), "--params", *TINY_PPO_PARAMS, "--run-dir", str(out / "r")],
        "bomb.yml",
        capsys,
        out,
    )


@pytest.mark.slow
def test_a_manifest_with_an_alias_bomb_in_its_notes_is_refused_naming_it(tmp_path, inputs, out, capsys):  # noqa: F811 - the fixtures
    text = (inputs / "manifest_good.yaml").read_text() + f"notes_bomb: &n {BOMB}\n"
    manifest = _write(tmp_path / "manifest_bomb.yaml", text)
    argv = ["calibrate", "validate", "--manifest", str(manifest), "--models", "point", "--drive-friction", "none"]
    _refused([*argv, "--json", str(out / "v.json")], "manifest_bomb.yaml", capsys, out)


@pytest.mark.slow
def test_a_log_with_one_huge_cell_gives_a_short_error(tmp_path, out, capsys):  # noqa: F811 - the fixture
    log = _write(
        tmp_path / "logs" / "huge.csv", "timestamp,roll_joint.position\n0,0.1\n20000000," + "9x" * 10_000_000 + "\n"
    )
    manifest = _manifest(tmp_path / "manifest.yaml", log)
    argv = ["calibrate", "validate", "--manifest", str(manifest), "--models", "point", "--drive-friction", "none"]
    _refused([*argv, "--json", str(out / "v.json")], "not a number", capsys, out)
    # _refused checked one error line; it is short
