"""The measured numbers of README.md and docs/ are the committed results files' numbers: every generated
block of every page equals what ``python -m evaluation.experiments.docs`` (``make docs``) renders from
``evaluation/results`` now."""

import json
import shutil

import pytest

from sphere_env.evaluation.experiments import RESULTS
from sphere_env.evaluation.experiments.docs import PAGES, ROOT, blocks, render_pages, render_text, stale_blocks
from sphere_env.evaluation.experiments.docs.base import RENDERERS, DocsError, Results


@pytest.fixture(scope="module")
def rendered():
    return render_pages(Results(RESULTS))


def test_every_page_equals_its_regenerated_text(rendered):
    stale = stale_blocks(rendered)
    assert not stale, "run `make docs`; out of date: " + "; ".join(stale)
    for page, (old, new) in rendered.items():
        assert old == new, f"{page} differs from its regenerated text (run `make docs`)"


def test_every_page_has_blocks_and_every_renderer_is_used(rendered):
    used = set()
    for page, (old, _) in rendered.items():
        names = [name for name, _ in blocks(old)]
        assert names, f"{page} has no generated block"
        used.update(names)
    assert used == set(RENDERERS), f"renderers no page uses: {sorted(set(RENDERERS) - used)}"


def test_unknown_block_name_is_refused_by_name():
    text = "before <!-- generated: no_such_block -->1.0<!-- /generated --> after"
    with pytest.raises(DocsError, match=r"notes\.md: unknown generated block 'no_such_block'"):
        render_text(text, Results(RESULTS), page="notes.md")


def test_unclosed_block_is_refused():
    with pytest.raises(DocsError, match="notes.md: .*needs its own"):
        render_text("<!-- generated: speed_table -->\n| a |\n", Results(RESULTS), page="notes.md")


def test_changed_results_value_shows_in_its_block(tmp_path):
    """A results file changed without `make docs` changes the rendered block, so the page check fails."""
    results = tmp_path / "results"
    shutil.copytree(RESULTS, results, ignore=shutil.ignore_patterns("*.png", "runs"))
    bench = json.loads((results / "benchmark.json").read_text())
    point = next(r for r in bench["twin"] if r["case"] == "twin, point")
    point["rtf"] = 12.345
    (results / "benchmark.json").write_text(json.dumps(bench))
    page = (ROOT / "docs/results/speed.md").read_text()
    new = render_text(page, Results(results), page="docs/results/speed.md")
    old_table = dict(blocks(page))["speed_table"]
    new_table = dict(blocks(new))["speed_table"]
    assert "**12.3×** real time" in new_table and "**12.3×**" not in old_table
    assert "≥ 40× (missed)" in new_table
    assert stale_blocks({"docs/results/speed.md": (page, new)}) == ["docs/results/speed.md: block speed_table"]


def test_every_results_page_is_generated():
    """Every page of docs/results/ has its numbers filled from the results files: it is one of PAGES."""
    results_pages = {str(p.relative_to(ROOT)) for p in (ROOT / "docs" / "results").glob("*.md")}
    assert results_pages and results_pages <= set(PAGES), results_pages - set(PAGES)
    for page in PAGES:
        assert (ROOT / page).is_file(), page


def test_fidelity_aims_flag_a_wide_interval_that_is_not_marked_unidentified():
    from sphere_env.evaluation.experiments.docs.calibration import _wide_unmarked

    rec = {"params": {"a": 1.0, "b": 0.1}, "ci95": {"a": (0.9, 1.1), "b": (-0.1, 0.3)}, "unidentified": {}}
    cal = {"steer_fit": {"models": {"injected": rec}}}
    assert _wide_unmarked(cal) == ["injected b"]
    rec["unidentified"] = {"b": "95 % interval wider than |value|"}
    assert _wide_unmarked(cal) == []
    old = {"provenance": {"hydroelastic_fit": {"values": {"f": 0.2}, "ci95": {"f": (0.0, 0.5)}}}}
    assert _wide_unmarked(old) == ["hydroelastic f"]
