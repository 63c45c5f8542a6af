"""The robustness script's interface fuzzer: every hostile CLI argument, calibration file and log
is refused with a named error and leaves nothing in its output folder."""

import pytest

from sphere_env.evaluation.experiments.robustness import fuzz_interfaces, interfaces_markdown


@pytest.mark.slow
def test_every_hostile_interface_input_is_refused_cleanly(tmp_path):
    res = fuzz_interfaces(tmp_path)
    bad = [r for r in res["cases"] if r["outcome"] != "clear error" or r["half_written"]]
    assert res["total"]["tried"] >= 80
    assert not bad, "\n".join(interfaces_markdown(res))
