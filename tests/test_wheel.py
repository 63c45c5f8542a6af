"""The built wheel works on its own: installed into a fresh venv and used from outside the repository.

The fresh venv borrows the third-party dependencies of the test's own environment through a
``.pth`` path entry (no download). A path entry does not run the ``.pth`` files of that folder,
so the editable ``sphere_env`` of the development venv stays invisible: the checks below assert
that ``sphere_env`` is imported from the fresh venv.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from email.parser import Parser
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
#: Repository folder -> package it installs as (pyproject.toml, [tool.setuptools.package-dir]).
INSTALLED_AS = {
    "sphere_env": "sphere_env",
    "assets": "sphere_env/assets",
    "training": "sphere_env/training",
    "evaluation": "sphere_env/evaluation",
}
SOURCES = ("pyproject.toml", "README.md", *INSTALLED_AS)
#: Development tooling of the repository that the wheel leaves out: the studies and the base their
#: recipes override.
NOT_INSTALLED = ("evaluation/experiments", "training/hyperparams/ppo_mixture.yml")
COMMANDS = ("train", "evaluate", "calibrate", "demo")

pytestmark = pytest.mark.slow

CHECK_ENVS = r"""
import json, sys
from pathlib import Path
import gymnasium as gym
import sphere_env
from sphere_env.params import SHELL_MODELS
from sphere_env.resources import asset_path, hyperparams_path

out = {"sphere_env": sphere_env.__file__, "prefix": sys.prefix, "runs": [],
       "files": [str(asset_path("robot", "roboball.urdf")), str(asset_path("logs", "roboball.yaml")),
                 str(hyperparams_path("ppo")), str(hyperparams_path("sac"))],
       "shell_models": list(SHELL_MODELS)}
for name in ("training", "evaluation"):
    try:
        __import__(name)
        out.setdefault("generic_top_level", []).append(name)
    except ImportError:
        pass
ids = sorted(i for i in gym.registry if i.startswith("sphere_env/"))
for env_id in ids:
    for shell in SHELL_MODELS:
        env = gym.make(env_id, shell_model=shell)
        obs, _ = env.reset(seed=0)
        obs, reward, terminated, truncated, _ = env.step(env.action_space.sample())
        out["runs"].append([env_id, shell, bool(env.observation_space.contains(obs)), float(reward)])
        env.close()
print(json.dumps(out))
"""


def _clean_env() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")}
    env["PYTHONNOUSERSITE"] = "1"
    return env


def _run(cmd, cwd: Path, timeout: float = 120) -> subprocess.CompletedProcess:
    proc = subprocess.run(
        [str(c) for c in cmd], cwd=cwd, env=_clean_env(), capture_output=True, text=True, timeout=timeout, check=False
    )
    assert proc.returncode == 0, f"{cmd} failed ({proc.returncode}):\n{proc.stdout[-2000:]}\n{proc.stderr[-4000:]}"
    return proc


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """The wheel, built without dependencies from a copy of the sources (no build/ left in the repo)."""
    tmp = tmp_path_factory.mktemp("wheel_build")
    src = tmp / "src"
    src.mkdir()
    for name in SOURCES:
        path = REPO / name
        if path.is_dir():
            shutil.copytree(path, src / name, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        else:
            shutil.copy2(path, src / name)
    _run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "--quiet", "-w", tmp / "dist", src],
        cwd=tmp,
        timeout=300,
    )
    wheels = list((tmp / "dist").glob("sphere_env-*.whl"))
    assert len(wheels) == 1, wheels
    return wheels[0]


@pytest.fixture(scope="module")
def fresh_venv(wheel, tmp_path_factory) -> Path:
    """A new venv holding only the wheel; dependencies come from this environment's site-packages."""
    venv = tmp_path_factory.mktemp("wheel_venv") / "venv"
    _run([sys.executable, "-m", "venv", "--without-pip", venv], cwd=venv.parent)
    py = venv / "bin" / "python"
    site = Path(
        _run([py, "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"], cwd=venv.parent).stdout.strip()
    )
    (site / "_project_deps.pth").write_text(sysconfig.get_path("purelib") + "\n")
    _run(
        [sys.executable, "-m", "pip", "--python", py, "install", "--no-deps", "--no-index", "--quiet", wheel],
        cwd=venv.parent,
    )
    return venv


def _installed(path: str) -> str:
    """The wheel path of a repository path (its top folder mapped as ``INSTALLED_AS`` says)."""
    top, _, rest = path.partition("/")
    return f"{INSTALLED_AS[top]}/{rest}"


def test_wheel_contents_and_metadata(wheel):
    names = zipfile.ZipFile(wheel).namelist()
    tops = {n.split("/", 1)[0] for n in names}
    assert tops == {"sphere_env", f"{wheel.name.split('-')[0]}-{wheel.name.split('-')[1]}.dist-info"}, tops
    results = [n for n in names if n.startswith("sphere_env/evaluation/results")]
    assert not results, f"committed results in the wheel: {results[:3]}"
    left_out = [n for n in names for path in NOT_INSTALLED if n.startswith(_installed(path))]
    assert not left_out, f"development tooling in the wheel: {left_out[:3]}"
    # Every package of the repository but the tooling is in the wheel (pyproject.toml lists them).
    for folder, installed in INSTALLED_AS.items():
        for init in (REPO / folder).rglob("__init__.py"):
            if any(init.is_relative_to(REPO / path) for path in NOT_INSTALLED):
                continue
            rel = init.relative_to(REPO / folder).as_posix()
            assert f"{installed}/{rel}" in names, f"package {init.parent} is missing from the wheel"
    # and no installed module imports the tooling
    wheel_file = zipfile.ZipFile(wheel)
    for name in (n for n in names if n.endswith(".py")):
        text = wheel_file.read(name).decode()
        assert not re.search(r"^\s*(from|import)\s+(sphere_env\.)?evaluation\.experiments", text, re.M), name
    for data in (
        "sphere_env/assets/robot/roboball.urdf",
        "sphere_env/assets/friction/presets.yaml",
        "sphere_env/assets/calibration/default.yaml",
        "sphere_env/assets/logs/roboball.yaml",
        "sphere_env/training/hyperparams/ppo.yml",
        "sphere_env/training/hyperparams/sac.yml",
        "sphere_env/py.typed",
    ):
        assert data in names, data
    for asset in (REPO / "assets").rglob("*"):
        if asset.is_file() and asset.suffix not in (".py", ".pyc"):
            assert f"sphere_env/assets/{asset.relative_to(REPO / 'assets').as_posix()}" in names, asset

    meta_name = next(n for n in names if n.endswith(".dist-info/METADATA"))
    meta = Parser().parsestr(zipfile.ZipFile(wheel).read(meta_name).decode())
    requires = meta.get_all("Requires-Dist")
    assert requires, "no dependencies declared"
    pinned = [r for r in requires if "==" in r.split(";")[0]]  # the marker has 'extra == "train"'
    assert not pinned, f"exact pins in the metadata: {pinned}"
    core = [r for r in requires if "extra ==" not in r]
    assert {re.split(r"[<>=!~ ;\[]", r, maxsplit=1)[0].lower() for r in core} >= {
        "drake",
        "gymnasium",
        "numpy",
        "scipy",
        "pyyaml",
    }
    sb3 = [r for r in requires if r.lower().startswith("stable-baselines3")]
    assert sb3 and all("<" in r for r in sb3), f"stable-baselines3 needs an upper bound: {sb3}"
    assert not [r for r in core if r.lower().startswith(("pillow", "torch", "stable-baselines3"))], core
    entry_points = zipfile.ZipFile(wheel).read(meta_name.replace("METADATA", "entry_points.txt")).decode()
    assert "sphere-env = sphere_env.cli:main" in entry_points


def test_wheel_builds_every_env_outside_the_repository(fresh_venv, tmp_path):
    proc = _run([fresh_venv / "bin" / "python", "-c", CHECK_ENVS], cwd=tmp_path, timeout=300)
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert Path(out["sphere_env"]).resolve().is_relative_to(fresh_venv.resolve()), out["sphere_env"]
    for path in out["files"]:
        assert Path(path).resolve().is_relative_to(fresh_venv.resolve()) and Path(path).is_file(), path
    assert "generic_top_level" not in out, out.get("generic_top_level")
    assert {"point", "injected", "hydroelastic"} <= set(out["shell_models"])
    ids = {r[0] for r in out["runs"]}
    assert {"sphere_env/RampDescent-v0", "sphere_env/Roll-v0"} <= ids, ids
    assert len(out["runs"]) == len(ids) * len(out["shell_models"]), out["runs"]
    for env_id, shell, obs_ok, reward in out["runs"]:
        assert obs_ok, f"{env_id} / {shell}: observation outside the observation space"
        assert reward == reward, f"{env_id} / {shell}: NaN reward"


def test_wheel_console_script_help(fresh_venv, tmp_path):
    exe = fresh_venv / "bin" / "sphere-env"
    assert exe.is_file()
    top = _run([exe, "--help"], cwd=tmp_path).stdout
    for cmd in COMMANDS:
        assert cmd in top
        usage = _run([exe, cmd, "--help"], cwd=tmp_path).stdout
        assert usage.startswith("usage:") and "--help" in usage, usage[:300]
