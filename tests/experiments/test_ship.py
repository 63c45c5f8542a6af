"""Shipping a policy refuses a bad candidate list by name before any evaluation or any write."""

from __future__ import annotations

import pytest

from sphere_env.evaluation.experiments.ship import main
from sphere_env.resources import shipped_policy_path


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("robust_residual", "allowed: recipe:seed or recipe:seed:steps"),
        ("robust_residual:0:x", "allowed: recipe:seed or recipe:seed:steps"),
        ("no_such_recipe:0", "recipe 'no_such_recipe' of 'no_such_recipe:0' is unknown"),
    ],
)
def test_a_bad_candidate_is_refused_by_name_and_the_shipped_policy_is_untouched(spec, message, capsys, tmp_path):
    card = shipped_policy_path("pretrained") / "card.json"
    before = card.read_bytes()
    with pytest.raises(SystemExit) as exc:
        main(["--candidates", "curriculum_scheduled:0", spec])
    assert exc.value.code == 2
    assert message in capsys.readouterr().err
    assert card.read_bytes() == before
