"""``calibrate events --write-manifest`` into an existing hand-written manifest: rewriting it would
drop its comments, so a manifest that holds any is refused by name, untouched; one without comments
(as the command writes them) still takes new trials."""

from __future__ import annotations

from sphere_env.calibration.__main__ import main
from sphere_env.calibration.manifest import load_manifest
from tests.calibration.test_windows_events import _release_log

TRIAL = "  - {name: first, file: r.csv, fixture: free}"


def test_a_manifest_with_comments_is_not_rewritten(tmp_path, capsys):
    log = _release_log(tmp_path / "r.csv")
    man = tmp_path / "hand.yaml"
    text = f"# trials of the 3 May session\ndata_root: .\ntrials:\n{TRIAL}  # the first push, by hand\n"
    man.write_text(text)
    assert main(["events", str(log), "--write-manifest", str(man)]) == 2
    err = capsys.readouterr().err
    assert "holds comments (line 1), which rewriting it would drop; nothing written" in err, err
    assert man.read_text() == text and sorted(p.name for p in tmp_path.iterdir()) == ["hand.yaml", "r.csv"]


def test_a_manifest_without_comments_takes_new_trials(tmp_path):
    log = _release_log(tmp_path / "r.csv")
    man = tmp_path / "plain.yaml"
    man.write_text(f"data_root: '.'\ntrials:\n{TRIAL[:-1]}, notes: 'run #2'}}\n")  # a '#' in a string: no comment
    assert main(["events", str(log), "--write-manifest", str(man), "--group", "g"]) == 0
    assert [t.name for t in load_manifest(man).trials][0] == "first" and len(load_manifest(man).trials) == 3
