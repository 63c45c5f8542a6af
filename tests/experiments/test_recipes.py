"""Every recipe of the learning study resolves to a training configuration that the trainer accepts:
its hyperparameters, env keyword arguments and callbacks validated against the built env, so a
recipe that could only fail once its job started is caught here."""

from __future__ import annotations

import pytest

from sphere_env.evaluation.experiments.learning import SECTION_RECIPE, load_recipes, phase_offset, recipe_config

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


def test_a_continuation_counts_its_steps_from_its_first_phase():
    """A continuation's checkpoints are numbered from its own start: every continuation recipe
    names a first recipe that exists and a step within that recipe's budget, which is its offset."""
    continuations = {k: r for k, r in RECIPES.items() if r.get("continue_from")}
    assert continuations
    for name, r in continuations.items():
        first = RECIPES[r["continue_from"]]
        assert 0 < phase_offset(r) <= float(first["n_timesteps"]), name
        assert phase_offset(r) == int(float(r["continue_at"]))
    assert all(phase_offset(r) == 0 for r in RECIPES.values() if not r.get("continue_from"))


def test_the_default_ppo_section_is_its_recipe():
    """``training/hyperparams/ppo.yml``'s RampDescent-v3 section (what ``sphere-env train`` and
    rl-zoo3 train by default) resolves to the configuration of ``SECTION_RECIPE``
    (``curriculum_scheduled``); the other recipes keep their frozen base file."""
    from sphere_env.resources import hyperparams_path
    from sphere_env.training.config import resolve_config

    recipe = RECIPES[SECTION_RECIPE]
    assert recipe["conf"] == "ppo_mixture"
    ours = recipe_config(recipe, seed=0)
    default = resolve_config(
        "sphere_env/RampDescent-v3",
        "ppo",
        hyperparams_path("ppo"),
        overrides={"n_workers": 1},
        seed=0,
        eval_freq=0,
        checkpoint_freq=int(float(recipe["eval_every"])),
    )

    def settings(cfg):
        return {k: v for k, v in cfg.as_dict().items() if k != "hyperparams_file"}

    assert settings(default) == settings(ours)
    assert settings(recipe_config(RECIPES["shipped"], seed=0)) != settings(ours)
