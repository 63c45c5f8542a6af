"""The committed v3 / v4 comparison (evaluation/results/drive_fit_envs.json): its v3 figures are the
learning study's baselines on the same grid (v3 unchanged by the drive fit), and only the shells a
shipped drive law applies to moved."""

import json
from pathlib import Path

import pytest

from sphere_env import safe_yaml
from sphere_env.resources import asset_path

RESULTS = Path(__file__).resolve().parents[2] / "evaluation" / "results"


def test_v3_figures_are_the_learning_baselines_and_only_applied_shells_moved():
    d = json.loads((RESULTS / "drive_fit_envs.json").read_text())
    base = json.loads((RESULTS / "learning" / "baselines.json").read_text())
    applied = set(safe_yaml.load_file(asset_path("calibration", "default.yaml"))["drive_law"]["shell_models"])
    for ctrl in ("pd", "pretrained"):
        v3, v4 = d["envs"]["sphere_env/RampDescent-v3"][ctrl], d["envs"]["sphere_env/RampDescent-v4"][ctrl]
        for key in ("success_rate", "tracking_rmse_rad_s", "per_shell"):
            assert v3[key] == pytest.approx(base[ctrl][key], rel=1e-6), (ctrl, key)  # the policy acts in float32
        for a, b in zip(v3["episodes_detail"], v4["episodes_detail"]):
            assert (a["shell_model"], a["pressure_kpa"], a["seed"]) == (b["shell_model"], b["pressure_kpa"], b["seed"])
            if a["shell_model"] not in applied:
                assert a == b
