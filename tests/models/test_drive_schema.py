"""The drive direction of a calibration file (``drive_law``, ``drive_fit``): bad input is refused by
name (the field, the value, what is allowed), and a file's applied law must be its recorded fit."""

import copy
import re

import pytest

from sphere_env import safe_yaml
from sphere_env.models.shell import ShellCalibration
from sphere_env.resources import asset_path

BASE = safe_yaml.load_file(asset_path("calibration", "default.yaml"))


def _with(**changes) -> dict:
    """default.yaml with ``section__key__...=value`` changes (``None`` deletes the key)."""
    raw = copy.deepcopy(BASE)
    for path, value in changes.items():
        *head, last = path.split("__")
        node = raw
        for key in head:
            node = node[key]
        if value is None:
            node.pop(last, None)
        else:
            node[last] = value
    return raw


INJECTED = "drive_fit__models__injected__"
BAD = {
    "friction scale out of range": (
        _with(drive_law__drive_friction_scale=11.0),
        ["drive_law.drive_friction_scale", "11.0", "within [0, 10]"],
    ),
    "friction scale as a string": (
        _with(drive_law__drive_friction_scale="3.4"),
        ["drive_law.drive_friction_scale", "'3.4'", "within [0, 10]"],
    ),
    "unknown shell model": (
        _with(drive_law__shell_models=["rigid"]),
        ["drive_law.shell_models", "rigid", "out of ['point', 'injected', 'hydroelastic']"],
    ),
    "shell model twice": (
        _with(drive_law__shell_models=["injected", "injected"]),
        ["drive_law.shell_models", "named twice"],
    ),
    "unknown drive_law key": (_with(drive_law__rolling_radius_m=0.3), ["drive_law.rolling_radius_m"]),
    "fitted as a string": (
        _with(drive_fit__fitted="yes"),
        ["field 'drive_fit.fitted' = 'yes'", "allowed: true or false"],
    ),
    "not fitted without a reason": (
        _with(drive_law=None, drive_fit={"fitted": False}),
        ["field 'drive_fit.reason' is missing", "fitted: false"],
    ),
    "not fitted with a record": (
        _with(drive_law=None, drive_fit={"fitted": False, "reason": "x", "commit": "abcdef1"}),
        ["field 'drive_fit.commit' is given with fitted: false", "allowed: only 'reason' and 'notes'"],
    ),
    "fitted without a commit": (
        _with(drive_fit__commit=None),
        ["field 'drive_fit.commit' is missing", "records ['log', 'fit_on', 'commit', 'models']"],
    ),
    "commit not a git id": (
        _with(drive_fit__commit="HEAD~2"),
        ["drive_fit.commit", "'HEAD~2'", "7-40 lowercase hex digits"],
    ),
    "fitted with a reason": (
        _with(drive_fit__reason="because"),
        ["field 'drive_fit.reason' = 'because'", "allowed: only with fitted: false"],
    ),
    "held out on the fitted window": (
        _with(drive_fit__held_out=["drive_forward"]),
        ["field 'drive_fit.held_out' = ['drive_forward']", "fitted on"],
    ),
    "window without its seconds": (
        _with(drive_fit__held_out=["drive_all"]),
        ["field 'drive_fit.windows_s' has no window 'drive_all'", "allowed: the windows of fit_on and held_out"],
    ),
    "unknown fitted parameter": (
        _with(**{INJECTED + "params": {"rolling_radius_m": 0.3}}),
        ["drive_fit.models.injected.params", "rolling_radius_m", "drive_friction_scale"],
    ),
    "applied flag as a number": (
        _with(**{INJECTED + "applied": 1}),
        ["field 'drive_fit.models.injected.applied' = 1", "allowed: true or false"],
    ),
    "not applied without why": (
        _with(drive_law=None, **{INJECTED + "applied": False}),
        ["field 'drive_fit.models.injected.not_applied_because' is missing"],
    ),
    "applied dissipation": (
        _with(drive_fit__models__hydroelastic__applied=True, drive_fit__models__hydroelastic__not_applied_because=None),
        ["drive_fit.models.hydroelastic", "dissipation_s_per_m", "cannot apply"],
    ),
    "law differs from the fit": (
        _with(drive_law__spin_damping_nms_per_rad=5.0),
        ["drive_law.spin_damping_nms_per_rad", "5.0", "drive_fit.models.injected.params.spin_damping_nms_per_rad"],
    ),
    "law for another model": (
        _with(drive_law__shell_models=["injected", "hydroelastic"]),
        ["drive_law.shell_models", "['injected', 'hydroelastic']", "allowed: the same models"],
    ),
    "applied fit without a law": (_with(drive_law=None), ["'drive_law' is missing", "['injected']"]),
    "law without a fit": (
        _with(drive_fit={"fitted": False, "reason": "not fitted"}),
        ["'drive_law' is given while 'drive_fit.fitted' is false"],
    ),
}


@pytest.mark.parametrize("case", list(BAD))
def test_bad_drive_section_is_refused_by_name(case):
    raw, words = BAD[case]
    with pytest.raises(ValueError) as err:
        ShellCalibration.from_dict(raw, source="bad.yaml")
    msg = str(err.value)
    assert "bad.yaml" in msg
    for w in words:
        assert w in msg, (case, w, msg)


def test_drive_law_alone_is_still_opt_in():
    """A user's file may carry a drive law without a record (the record is what shipped files add)."""
    raw = _with(drive_fit=None, drive_law={"spin_damping_nms_per_rad": 3.0})
    cal = ShellCalibration.from_dict(raw)
    assert cal.drive_law_of("hydroelastic").spin_damping_nms_per_rad == 3.0
    assert cal.drive_law_of("injected").friction_scale == 1.0
    assert cal.without_drive_law().drive_law_of("hydroelastic").spin_damping_nms_per_rad == 0.0


def test_the_shipped_law_is_the_recorded_fit():
    cal = ShellCalibration.load("default")
    fit = BASE["drive_fit"]["models"]["injected"]["params"]
    got = cal.drive_law_of("injected")
    assert (got.friction_scale, got.rolling_damping_factor, got.spin_damping_nms_per_rad) == (
        fit["drive_friction_scale"],
        fit["injected_rolling_damping_factor"],
        fit["spin_damping_nms_per_rad"],
    )
    assert re.fullmatch(r"[0-9a-f]{40}", BASE["drive_fit"]["commit"])
