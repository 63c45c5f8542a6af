"""Watch and record: ``--video`` on the evaluation and the enjoy command write one readable MP4 per
episode (a frame at the reset and one per step), named by controller, shell model, pressure and
seed, moved into place only on success; rendering leaves the episodes unchanged; the enjoy command
rolls a run folder out as the evaluation does and refuses bad run folders and inputs by name."""

from __future__ import annotations

import shutil

import pytest

from sphere_env.evaluation.enjoy import EnjoySpec, enjoy
from sphere_env.evaluation.enjoy import main as enjoy_main
from sphere_env.evaluation.evaluate import SweepSpec, evaluate

SMALL = {"render_size": [96, 72]}  # small frames keep the tests fast (h264 wants even sizes)


def n_frames(path) -> int:
    import imageio.v2 as iio

    reader = iio.get_reader(str(path), format="FFMPEG")
    try:
        return sum(1 for _ in reader)
    finally:
        reader.close()


def _cell(controllers, **kw):
    return SweepSpec(
        controllers=controllers, pressures_kpa=[8.5], shell_models=["point"], seeds=[0], env_kwargs=dict(SMALL), **kw
    )


@pytest.mark.slow
def test_evaluate_video_writes_one_mp4_per_episode_and_leaves_episodes_unchanged(tmp_path):
    plain = evaluate(_cell(["zero"]), tmp_path / "plain", workers=1, replays=[], plots=False)
    res = evaluate(_cell(["zero"]), tmp_path / "eval", workers=1, replays=[], plots=False, video=tmp_path / "videos")
    (row,) = res["rows"]
    assert [p.name for p in (tmp_path / "videos").iterdir()] == ["zero_point_8.5kPa_s0.mp4"]
    # a frame at the reset and one per step; ffmpeg's reader may drop the last frame of a clip
    assert n_frames(tmp_path / "videos" / "zero_point_8.5kPa_s0.mp4") in (row["length"], row["length"] + 1)
    (plain_row,) = plain["rows"]
    assert row == plain_row
    assert res["files"]["video zero_point_8.5kPa_s0"] == tmp_path / "videos" / "zero_point_8.5kPa_s0.mp4"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["eval", "plain", "videos"]  # no staging left


def test_evaluate_video_failure_leaves_no_video(tmp_path):
    with pytest.raises(RuntimeError, match="mid-episode"):
        evaluate(
            _cell(["late=tests.evaluation.test_eval_cli:FailsLater"]),
            tmp_path / "o",
            workers=1,
            replays=[],
            plots=False,
            video=tmp_path / "new" / "videos",
        )
    assert list(tmp_path.iterdir()) == []


def test_evaluate_bad_video_folder_refused(tmp_path):
    f = tmp_path / "file"
    f.write_text("keep")
    with pytest.raises(ValueError, match="^field 'video' = .*is a file"):
        evaluate(_cell(["zero"]), tmp_path / "o", workers=1, replays=[], video=f / "sub")
    with pytest.raises(ValueError, match="^field 'video' = .*not available with --ray-address"):
        evaluate(_cell(["zero"]), tmp_path / "o", ray_address="local", replays=[], video=tmp_path / "v")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]


@pytest.mark.slow
def test_enjoy_records_the_evaluations_episodes(tiny_ppo_run, tmp_path):
    rows = enjoy(
        EnjoySpec(run=str(tiny_ppo_run), episodes=2, pressure_kpa=8.5, seed=3, env_kwargs=dict(SMALL)),
        video=tmp_path / "videos",
        say=lambda _: None,
    )
    names = sorted(p.name for p in (tmp_path / "videos").iterdir())
    assert names == ["run_point_8.5kPa_s3.mp4", "run_point_8.5kPa_s4.mp4"]
    for row, name in zip(rows, names):
        assert n_frames(tmp_path / "videos" / name) in (row["length"], row["length"] + 1)
    ev = evaluate(
        SweepSpec(
            controllers=[str(tiny_ppo_run)],
            env_id="sphere_env/RampDescent-v2",
            pressures_kpa=[8.5],
            shell_models=["point"],
            seeds=[3, 4],
        ),
        tmp_path / "eval",
        workers=1,
        replays=[],
        plots=False,
    )
    for mine, theirs in zip(rows, ev["rows"]):
        assert (mine["return"], mine["length"], mine["seed"]) == (theirs["return"], theirs["length"], theirs["seed"])


def test_enjoy_stochastic_actions_are_seeded(tiny_ppo_run):
    def returns(seed, deterministic):
        rows = enjoy(
            EnjoySpec(run=str(tiny_ppo_run), pressure_kpa=8.5, seed=seed, deterministic=deterministic),
            say=lambda _: None,
        )
        return rows[0]["return"]

    assert returns(1, False) == returns(1, False)
    assert returns(1, False) != returns(1, True)


def _broken_copy(run, tmp_path, remove=None, truncate=None):
    copy = tmp_path / "copy"
    shutil.copytree(run, copy)
    if remove:
        (copy / remove).unlink()
    if truncate:
        data = (copy / truncate).read_bytes()
        (copy / truncate).write_bytes(data[: len(data) // 3])
    return str(copy)


@pytest.mark.parametrize(
    "case, needles",
    [
        ("no_config", ["run:", "config.yaml"]),
        ("no_model", ["run:", "model.zip", "is missing"]),
        ("no_vecnormalize", ["run:", "vecnormalize.json", "is missing"]),
        ("truncated_model", ["run:", "model.zip", "truncated"]),
        ("not_a_folder", ["field 'run'", "is not a folder"]),
        ("bad_which", ["field 'run' = ", "@last", "@best"]),
        ("no_best", ["run:", "best_model.zip"]),
        ("other_env", ["env:", "trained on 'sphere_env/RampDescent-v2'", "--allow-env-mismatch"]),
        ("shell", ["field 'shell_model' = 'jelly'"]),
        ("pressure", ["pressure_kpa", "99"]),
        ("episodes", ["field 'episodes' = 0"]),
        ("seed", ["field 'seed' = -1"]),
        ("env_kwargs", ["env_kwargs.randomization"]),
        ("video_file", ["field 'video'", "is a file"]),
    ],
)
def test_enjoy_refuses_bad_input_by_name(tiny_ppo_run, tmp_path, capsys, case, needles):
    run = str(tiny_ppo_run)
    argv = {
        "no_config": lambda: [_broken_copy(tiny_ppo_run, tmp_path, remove="config.yaml")],
        "no_model": lambda: [_broken_copy(tiny_ppo_run, tmp_path, remove="model.zip")],
        "no_vecnormalize": lambda: [_broken_copy(tiny_ppo_run, tmp_path, remove="vecnormalize.json")],
        "truncated_model": lambda: [_broken_copy(tiny_ppo_run, tmp_path, truncate="model.zip")],
        "not_a_folder": [str(tmp_path / "nothing")],
        "bad_which": [run + "@last"],
        "no_best": lambda: [_broken_copy(tiny_ppo_run, tmp_path, remove="best/best_model.zip") + "@best"],
        "other_env": [run, "--env", "sphere_env/Roll-v1"],
        "shell": [run, "--shell-model", "jelly"],
        "pressure": [run, "--pressure-kpa", "99"],
        "episodes": [run, "--episodes", "0"],
        "seed": [run, "--seed", "-1"],
        "env_kwargs": [run, "--env-kwargs", "{randomization: full}"],
        "video_file": [run, "--video", str(tmp_path / "f" / "v")],
    }[case]
    argv = argv() if callable(argv) else argv
    (tmp_path / "f").write_text("a file")
    with pytest.raises(SystemExit) as exc:
        enjoy_main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    for n in needles:
        assert n in err, err
    assert sorted(p.name for p in tmp_path.iterdir() if p.name != "copy") == ["f"]  # nothing written


def test_enjoy_on_another_env_with_another_layout_is_refused_even_when_allowed(tiny_ppo_run):
    # v0 observes 13 numbers, the v2 policy reads 16
    with pytest.raises(ValueError, match=r"controller: .*shape \(16,\).*\(13,\)"):
        enjoy(
            EnjoySpec(run=str(tiny_ppo_run), env_id="sphere_env/RampDescent-v0", allow_env_mismatch=True),
            say=lambda _: None,
        )
