"""Output files are written whole or not at all."""

from __future__ import annotations

import os

import pytest

from sphere_env.files import swap_folder, write_text_atomic


def test_an_exclusive_write_never_replaces_a_file_and_leaves_no_temporary(tmp_path):
    target = tmp_path / "sweep.yaml"
    write_text_atomic(target, "first\n", exclusive=True)
    with pytest.raises(FileExistsError):
        write_text_atomic(target, "second\n", exclusive=True)
    assert target.read_text() == "first\n"
    write_text_atomic(target, "third\n")  # the plain write replaces it
    assert target.read_text() == "third\n"
    assert [p.name for p in tmp_path.iterdir()] == ["sweep.yaml"]


def test_a_folder_swap_replaces_the_outputs_as_a_set_and_keeps_other_files(tmp_path):
    out, work = tmp_path / "out", tmp_path / "work"
    out.mkdir()
    work.mkdir()
    (out / "report.md").write_text("old")
    (out / "stale.csv").write_text("old")
    (out / "notes.txt").write_text("mine")
    (work / "report.md").write_text("new")
    swap_folder(work, out, produced=lambda name: name != "notes.txt")
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt", "report.md"]
    assert (out / "report.md").read_text() == "new" and (out / "notes.txt").read_text() == "mine"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


@pytest.mark.parametrize("umask", [0o022, 0o077], ids=["umask 022", "umask 077"])
def test_an_atomic_write_gives_the_file_the_umask_mode_not_the_temporary_files(tmp_path, umask):
    old = os.umask(umask)
    try:
        out = write_text_atomic(tmp_path / "results.json", "{}\n")
    finally:
        os.umask(old)
    assert out.stat().st_mode & 0o777 == 0o666 & ~umask
