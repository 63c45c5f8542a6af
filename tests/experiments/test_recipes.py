"""Every recipe of the learning study resolves to a training configuration that the trainer accepts:
its hyperparameters, env keyword arguments and callbacks validated against the built env, so a
recipe that could only fail once its job started is caught here."""

from __future__ import annotations

import pytest

from sphere_env.evaluation.experiments.learning import load_recipes, recipe_config

RECIPES = load_recipes()


@pytest.mark.parametrize("name", sorted(RECIPES))
def test_every_recipe_resolves_to_a_training_configuration(name):
    recipe = RECIPES[name]
    cfg = recipe_config(recipe, seed=0)
    assert cfg.n_timesteps == int(float(recipe["n_timesteps"]))
    assert cfg.seed == 0


def test_a_recipe_with_a_bad_field_is_refused_by_name():
    recipe = {**RECIPES["batch32_curriculum"], "env_kwargs": {"randomization": {"pressure_kpa": [3.0, 99.0]}}}
    with pytest.raises(ValueError, match="pressure_kpa"):
        recipe_config(recipe, seed=0)
