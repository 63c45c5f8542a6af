"""Output paths a user's text cannot bend: a controller label becomes a safe file name (never a
path out of ``--out``), two labels that would share a file name are refused by name before anything
runs, and an output folder's name may be as long as the file system allows (the temporary names
beside it stay bounded)."""

from __future__ import annotations

import pytest

from sphere_env.cli import main
from sphere_env.files import file_stem, write_text_atomic

GRID = ["--shell-models", "point", "--pressure-kpa", "8.5", "--seeds", "0", "--workers", "1"]
#: The longest file name most file systems take (NAME_MAX).
NAME_MAX = 255


def _files(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def test_a_label_naming_a_path_writes_its_replay_inside_out(tmp_path, capsys):
    out = tmp_path / "a" / "b" / "out"
    main(["evaluate", "--controller", "../../escaped=zero", *GRID, "--out", str(out)])
    capsys.readouterr()
    outside = [f for f in _files(tmp_path) if not f.startswith("a/b/out")]
    assert outside == ["a", "a/b"], outside
    replays = [f for f in _files(out) if f.startswith("replay_")]
    assert replays == ["replay_-.-..-escaped_point_8.5kPa_s0.html"]
    assert "../../escaped" in (out / "episodes.csv").read_text()  # the label itself is kept as data


@pytest.mark.parametrize("text", ["../x", "a/b", "..", ".", ".hidden", "a\\b", "x\0y", "ω" * 300, "l" * 1000], ids=repr)
def test_every_label_gives_one_short_visible_file_name_part(tmp_path, text):
    from sphere_env.evaluation.video import video_name

    stem = file_stem(text)
    assert "/" not in stem and "\0" not in stem and not stem.startswith(".") and 0 < len(stem) <= 64
    name = video_name(text, "hydroelastic", 8.5, 0, "calibration:free_robot") + ".mp4"
    assert "/" not in name and len(name) < NAME_MAX
    assert write_text_atomic(tmp_path / name, "x").parent == tmp_path


def test_two_labels_with_one_file_name_are_refused_before_anything_runs(tmp_path, capsys):
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as exc:
        main(["evaluate", "--controller", "a/b=zero", "a-b=pd", *GRID, "--out", str(out)])
    err = capsys.readouterr().err.strip()
    assert exc.value.code == 2 and len(err.splitlines()) == 1, err
    assert "field 'controllers'" in err and "'a/b' and 'a-b'" in err and "'a-b'" in err, err
    assert "allowed: labels whose file names differ" in err
    assert not list(tmp_path.iterdir())


def test_an_out_folder_named_as_long_as_the_file_system_allows_takes_the_sweep_twice(tmp_path, capsys):
    """The staging folder (``.<name>.partial-...``) and the replaced outputs (``.<name>.old-...``)
    beside ``--out`` have bounded names, so a 255-character folder name works, new and reused."""
    out = tmp_path / ("o" * NAME_MAX)
    for _ in range(2):
        main(["evaluate", "--controller", "zero", *GRID, "--replay", "--out", str(out)])
        assert "episodes.csv" in _files(out)
        assert [p.name for p in tmp_path.iterdir()] == [out.name]  # nothing left beside it
    capsys.readouterr()


def test_a_file_named_as_long_as_the_file_system_allows_is_written_atomically(tmp_path):
    path = write_text_atomic(tmp_path / ("f" * NAME_MAX), "text\n")
    assert path.read_text() == "text\n" and [p.name for p in tmp_path.iterdir()] == [path.name]
