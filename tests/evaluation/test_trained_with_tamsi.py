"""A policy trained with the fast contact solver is evaluated under the reference physics."""

import shutil

import yaml

from sphere_env.evaluation.controller_specs import env_kwargs_of
from sphere_env.resources import shipped_policy_path


def test_a_run_trained_with_tamsi_is_evaluated_without_it(tmp_path):
    run = tmp_path / "run"
    shutil.copytree(shipped_policy_path("pretrained"), run)
    config = yaml.safe_load((run / "config.yaml").read_text())
    shipped = env_kwargs_of(str(run))
    config["env_kwargs"]["contact_approximation"] = "tamsi"
    (run / "config.yaml").write_text(yaml.safe_dump(config))
    kwargs = env_kwargs_of(str(run))
    assert "contact_approximation" not in kwargs
    assert kwargs == shipped  # the observation options the policy needs are kept
    assert kwargs["observe_pressure"] is True
