"""Plan files: schema, defaults and overrides, every error message (realisation:
tests/plans/test_realise.py)."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from inkarm.errors import ScenarioError
from inkarm.io.planfile import load_plan, parse_plan

BASIC = """
title = "two strokes"
cov = 4.0
[model]
order = 3
d = 2.0
segment_time = 0.2
[[strokes]]
targets = [{ mean = [0.0, 0.0] }, { mean = [10.0, 20.0] }, { mean = [20.0, 0.0] }]
[[strokes]]
model = { order = 5, r = 1e-6 }
cov = [1.0, 9.0]
targets = [{ mean = [30.0, 0.0] }, { mean = [40.0, 10.0], cov = [[4.0, 1.0], [1.0, 2.0]] }]
"""


def parse(text: str, seed: int | None = None):
    return parse_plan(tomllib.loads(text), source="plan.toml", seed=seed)


def with_target(extra: str) -> str:
    return f"""
[[strokes]]
targets = [{{ mean = [0.0, 0.0], cov = 1.0 }}, {{ mean = [5.0, 5.0], {extra} }}]
"""


def test_defaults_overrides_and_covariance_forms():
    plan = parse(BASIC)
    assert (
        plan.title == "two strokes" and plan.samples == 0 and plan.seed == 0 and plan.pause == 0.5
    )
    first, second = plan.strokes
    assert first.kind == "gaussian" and first.model["order"] == 3 and first.model["d"] == 2.0
    assert first.plan.segment_time == 0.2 and not first.plan.keypoints
    np.testing.assert_allclose(first.plan.covs, np.broadcast_to(np.eye(2) * 4.0, (3, 2, 2)))
    # a stroke's r replaces the inherited d; other settings stay inherited
    assert second.model["order"] == 5 and second.model["r"] == 1e-6 and second.model["d"] is None
    assert second.model["segment_time"] == 0.2
    np.testing.assert_allclose(second.plan.covs[0], np.diag([1.0, 9.0]))
    np.testing.assert_allclose(second.plan.covs[1], [[4.0, 1.0], [1.0, 2.0]])


def test_std_and_angle_give_a_rotated_covariance():
    plan = parse(with_target("std = [3.0, 1.0], angle = 90"))
    np.testing.assert_allclose(plan.strokes[0].plan.covs[1], np.diag([1.0, 9.0]), atol=1e-12)
    plan = parse(with_target("std = 2.0"))
    np.testing.assert_allclose(plan.strokes[0].plan.covs[1], np.eye(2) * 4.0)


def test_keypoints_default_to_identity_and_3d_targets_are_accepted():
    plan = parse("""
[[strokes]]
kind = "keypoints"
targets = [{ mean = [0.0, 0.0, 1.0] }, { mean = [5.0, 5.0, 1.0] }]
""")
    stroke = plan.strokes[0]
    assert stroke.plan.keypoints and plan.dim == 3
    np.testing.assert_allclose(stroke.plan.covs, np.eye(3)[None].repeat(2, axis=0))


def test_semi_tied_generates_aligned_covariances_and_stroke_settings_override():
    text = """
seed = 3
[semi_tied]
H = [[1.0, 0.5], [0.0, 1.0]]
h = 4.0
[[strokes]]
targets = [{ mean = [0.0, 0.0] }, { mean = [5.0, 5.0], cov = 1.0 }, { mean = [9.0, 0.0] }]
[[strokes]]
semi_tied = { rho = 1.0 }
targets = [{ mean = [0.0, 0.0] }, { mean = [5.0, 5.0] }, { mean = [9.0, 0.0] }]
"""
    plan = parse(text)
    basis = np.array([[1.0, 0.5], [0.0, 1.0]])
    covs = plan.strokes[0].plan.covs
    np.testing.assert_allclose(covs[0], 4.0 * basis @ basis.T)  # seed 000 eq. 22, rho = 0
    np.testing.assert_allclose(covs[1], np.eye(2))  # an explicit cov wins
    spread = plan.strokes[1].plan.covs
    scales = spread[:, 0, 1] / (basis @ basis.T)[0, 1]
    np.testing.assert_allclose(spread, scales[:, None, None] * (basis @ basis.T)[None])
    assert np.ptp(scales) > 0  # rho > 0 perturbs h per target
    np.testing.assert_allclose(parse(text).strokes[1].plan.covs, spread)  # same seed, same plan
    assert not np.allclose(parse(text, seed=4).strokes[1].plan.covs, spread)


def test_human_line_and_minjerk_strokes():
    plan = parse("""
[human_line]
squiggle = 3.0
[[strokes]]
kind = "human_line"
points = [[0.0, 0.0], [30.0, 0.0], [30.0, 30.0]]
human_line = { duration = 1.0 }
[[strokes]]
kind = "minjerk"
points = [[0.0, 0.0], [10.0, 10.0], [20.0, 0.0]]
minjerk = { duration = 0.8, via_times = [0.3] }
""")
    line, mj = plan.strokes
    assert line.options == {"squiggle": 3.0, "px_mm": pytest.approx(25.4 / 300), "duration": 1.0}
    assert mj.options["duration"] == 0.8 and mj.options["via_times"].tolist() == [0.3]


def test_load_plan_reads_a_file_and_reports_syntax_errors(tmp_path):
    path = tmp_path / "plan.toml"
    path.write_text(BASIC)
    assert len(load_plan(path).strokes) == 2
    path.write_text("[model\norder = 4\n")
    with pytest.raises(ScenarioError, match=r"plan.toml: not valid TOML"):
        load_plan(path)
    with pytest.raises(ScenarioError, match=r"missing.toml: no such plan file"):
        load_plan(tmp_path / "missing.toml")


BAD_CASES = [
    # unknown and mistyped keys, with suggestions
    (
        "titel = 'x'\n" + with_target("cov = 1.0"),
        r"plan.toml: titel: unknown key \(did you mean 'title'\?\)",
    ),
    (
        "[model]\nsegement_time = 0.2\n" + with_target("cov = 1.0"),
        r"plan.toml: model.segement_time: unknown key \(did you mean 'segment_time'\?\)",
    ),
    (
        with_target("covv = 1.0"),
        r"strokes\[0\].targets\[1\].covv: unknown key \(did you mean 'cov'\?\)",
    ),
    (
        "[[strokes]]\ntarget = []\n",
        r"strokes\[0\].target: unknown key \(did you mean 'targets'\?\)",
    ),
    (
        "[[strokes]]\nmodel = { dd = 1.0 }\ntargets = [{ mean = [0.0, 0.0], cov = 1.0 }]\n",
        r"strokes\[0\].model.dd: unknown key \(did you mean 'd'\?\)",
    ),
    (
        "[[strokes]]\nkind = 'gausian'\n",
        r"strokes\[0\].kind: unknown value 'gausian' \(did you mean 'gaussian'\?\)",
    ),
    # wrong types and values
    (
        "[model]\norder = 4.5\n" + with_target("cov = 1.0"),
        r"model.order: expected an integer, got 4.5 \(float\)",
    ),
    (
        "[model]\norder = 9\n" + with_target("cov = 1.0"),
        r"model.order: expected an integer in 1..7, got 9",
    ),
    (
        "[model]\ndt = 'fast'\n" + with_target("cov = 1.0"),
        r"model.dt: expected a number, got 'fast' \(str\)",
    ),
    (
        "[model]\nd = nan\n" + with_target("cov = 1.0"),
        r"model.d: expected a finite number, got nan",
    ),
    ("[model]\nd = -1.0\n" + with_target("cov = 1.0"), r"model.d: expected a number > 0, got -1.0"),
    (
        "[model]\nd = 1.0\nr = 1.0\n" + with_target("cov = 1.0"),
        r"model: give one of d .* and r .*, not both",
    ),
    (
        "[model]\nend_at_rest = 1\n" + with_target("cov = 1.0"),
        r"model.end_at_rest: expected true or false, got 1",
    ),
    (
        "[model]\ndt = 0.1\nsegment_time = 0.05\n" + with_target("cov = 1.0"),
        r"model.segment_time: segment_time \(0.05 s\) must be at least dt \(0.1 s\)",
    ),
    ("samples = -1\n" + with_target("cov = 1.0"), r"samples: expected an integer >= 0, got -1"),
    (
        "seed = true\n" + with_target("cov = 1.0"),
        r"seed: expected an integer, got true \(boolean\)",
    ),
    (
        "model = 3\n" + with_target("cov = 1.0"),
        r"plan.toml: model: expected a table, got 3 \(int\)",
    ),
    # targets and covariances
    (
        with_target("cov = [[1.0, 0.0], [0.0, -1.0]]"),
        r"plan.toml: strokes\[0\].targets\[1\].cov: covariance is not positive definite",
    ),
    (
        with_target("cov = [[1.0, 0.5], [0.0, 1.0]]"),
        r"strokes\[0\].targets\[1\].cov: covariance is not symmetric",
    ),
    (
        with_target("cov = [1.0, 2.0, 3.0]"),
        r"targets\[1\].cov: diagonal covariance has 3 entries, expected 2",
    ),
    (with_target("cov = [[1.0, 0.0], [0.0]]"), r"targets\[1\].cov: rows have different lengths"),
    (with_target("cov = nan"), r"strokes\[0\].targets\[1\].cov: expected a finite number, got nan"),
    (
        with_target("cov = 1.0, std = 1.0"),
        r"strokes\[0\].targets\[1\]: give one of cov and std, not both",
    ),
    (with_target("cov = 1.0, angle = 3.0"), r"targets\[1\].angle: only allowed together with std"),
    (with_target("std = [1.0, -2.0]"), r"targets\[1\].std: standard deviations must be positive"),
    (with_target("std = [1.0]"), r"targets\[1\].std: has 1 entries, expected 2"),
    (
        "[[strokes]]\ntargets = [{ mean = [0.0, 0.0] }]\n",
        r"strokes\[0\].targets\[0\]: no covariance: give cov or std, or a cov or \[semi_tied\]",
    ),
    ("[[strokes]]\ntargets = [{ cov = 1.0 }]\n", r"strokes\[0\].targets\[0\].mean: required"),
    (
        "[[strokes]]\ntargets = [{ mean = [0.0, 'a'], cov = 1.0 }]\n",
        r"strokes\[0\].targets\[0\].mean\[1\]: expected a number, got 'a'",
    ),
    (
        "[[strokes]]\ntargets = [{ mean = [0.0], cov = 1.0 }]\n",
        r"targets\[0\].mean: expected 2 or 3 coordinates, got 1",
    ),
    (
        "[[strokes]]\ntargets = [{ mean = [0.0, 0.0], cov = 1.0 }, { mean = [1.0, 1.0, 1.0], cov = 1.0 }]\n",
        r"targets\[1\].mean: has 3 coordinates but strokes\[0\].targets\[0\] has 2",
    ),
    ("[[strokes]]\ntargets = []\n", r"strokes\[0\].targets: expected a non-empty array"),
    ("[[strokes]]\nkind = 'gaussian'\n", r"strokes\[0\].targets: required for a gaussian stroke"),
    # strokes, kinds and sections
    ("title = 'nothing'\n", r"plan.toml: strokes: required: at least one \[\[strokes\]\] table"),
    ("strokes = 3\n", r"strokes: expected at least one \[\[strokes\]\] table"),
    (
        "[[strokes]]\nkind = 'human_line'\n",
        r"strokes\[0\].points: required for a human_line stroke",
    ),
    (
        "[[strokes]]\nkind = 'human_line'\npoints = [[0.0, 0.0]]\n",
        r"strokes\[0\].points: expected at least 2 points",
    ),
    (
        "[[strokes]]\nkind = 'minjerk'\npoints = [[0.0, 0.0], [1.0, 1.0]]\ncov = 1.0\n",
        r"strokes\[0\].cov: not used by a minjerk stroke",
    ),
    (
        "[[strokes]]\npoints = [[0.0, 0.0], [1.0, 1.0]]\n",
        r"strokes\[0\].points: not used by a gaussian stroke",
    ),
    (
        "[[strokes]]\nkind = 'minjerk'\npoints = [[0.0, 0.0], [1.0, 1.0]]\nhuman_line = { squiggle = 1.0 }\n",
        r"strokes\[0\].human_line: only applies to human_line strokes, this one is minjerk",
    ),
    (
        "[[strokes]]\nkind = 'minjerk'\npoints = [[0.0, 0.0], [1.0, 1.0], [2.0, 0.0]]\nminjerk = { via_times = [0.1, 0.2] }\n",
        r"strokes\[0\].minjerk.via_times: expected 1 times for the 1 via-points, got 2",
    ),
    (
        "[human_line]\nsquigle = 2.0\n" + with_target("cov = 1.0"),
        r"human_line.squigle: unknown key \(did you mean 'squiggle'\?\)",
    ),
    (
        "[human_line]\npx_mm = 0.0\n" + with_target("cov = 1.0"),
        r"human_line.px_mm: expected a number > 0, got 0.0",
    ),
    # semi-tied
    (
        "[semi_tied]\nH = [[1.0, 0.0], [0.0, 1.0]]\n" + with_target("cov = 1.0"),
        r"semi_tied.h: required",
    ),
    (
        "[semi_tied]\nh = 1.0\nH = [[1.0, 2.0], [0.5, 1.0]]\n" + with_target("cov = 1.0"),
        r"semi_tied.H: the basis is singular",
    ),
    (
        "[semi_tied]\nh = 1.0\nH = [[1.0, 2.0, 3.0]]\n" + with_target("cov = 1.0"),
        r"semi_tied.H: expected a 2 x 2 or 3 x 3 matrix, got shape \(1, 3\)",
    ),
    (
        "[semi_tied]\nh = 1.0\nrho = -1.0\n" + with_target("cov = 1.0"),
        r"semi_tied.rho: expected a number >= 0",
    ),
    (
        "cov = 1.0\n[semi_tied]\nh = 1.0\n" + with_target("cov = 1.0"),
        r"plan.toml: give one of the top-level cov and \[semi_tied\]",
    ),
    (
        "[[strokes]]\ncov = 1.0\nsemi_tied = { h = 1.0 }\ntargets = [{ mean = [0.0, 0.0] }]\n",
        r"strokes\[0\]: give one of cov and semi_tied, not both",
    ),
    (
        (
            "[[strokes]]\nsemi_tied = { h = 1.0, H = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] }\n"
            "targets = [{ mean = [0.0, 0.0] }]\n"
        ),
        r"strokes\[0\].semi_tied.H: is 3 x 3 but the targets are 2-D",
    ),
    # numbers out of range: each names the key, the range and the value
    (
        with_target("std = 1e300"),
        (r"plan.toml: strokes\[0\].targets\[1\].std: expected numbers in \[1e-06, 1e\+06\] mm, "
        r"got 1e\+300$"),
    ),
    (with_target("std = [2.0, 1e-300]"), r"targets\[1\].std: expected numbers .*got 1e-300$"),
    (
        with_target("std = [1e-6, 1e5]"),
        r"targets\[1\].std: condition number 1e\+22 .*more than 1e\+12: nearly singular",
    ),
    (
        with_target("cov = 1e300"),
        (r"targets\[1\].cov: expected variances in \[1e-12, 1e\+12\] mm\^2 \(std 1e-06 to "
        r"1e\+06 mm\), got 1e\+300$"),
    ),
    (
        with_target("cov = [[1e200, 0.0], [0.0, 1e-200]]"),
        r"targets\[1\].cov: expected variances .*got 1e\+200$",
    ),
    (
        with_target("cov = 1e-300"),
        (r"targets\[1\].cov: expected variances \(eigenvalues\) in \[1e-12, 1e\+12\] mm\^2 .*"
        r"got 1e-300$"),
    ),
    (
        with_target("cov = [[1e6, 999999.9999999], [999999.9999999, 1e6]]"),
        r"targets\[1\].cov: condition number .*nearly singular",
    ),
    (
        "[[strokes]]\ntargets = [{ mean = [1e300, 0.0], cov = 1.0 }]\n",
        (r"strokes\[0\].targets\[0\].mean: expected coordinates in \[-1e\+06, 1e\+06\] mm, "
        r"got 1e\+300$"),
    ),
    (
        "[[strokes]]\nkind = 'human_line'\npoints = [[0.0, 0.0], [0.0, -1e7]]\n",
        r"strokes\[0\].points: expected coordinates .*got -1e\+07$",
    ),
    (
        "[model]\ndt = 1e-6\n" + with_target("cov = 1.0"),
        r"model.dt: expected a number in \[0.0001, 1\] s, got 1e-06$",
    ),
    ("[model]\ndt = 2.0\n" + with_target("cov = 1.0"), r"model.dt: .*\[0.0001, 1\] s, got 2$"),
    (
        "[model]\nd = 1e-300\n" + with_target("cov = 1.0"),
        r"model.d: expected a number in \[1e-06, 1e\+06\] mm, got 1e-300$",
    ),
    (
        "[[strokes]]\nmodel = { d = 1e300 }\ntargets = [{ mean = [0.0, 0.0], cov = 1.0 }]\n",
        r"strokes\[0\].model.d: expected a number in \[1e-06, 1e\+06\] mm, got 1e\+300$",
    ),
    (
        "[model]\nr = 1e-300\n" + with_target("cov = 1.0"),
        r"model.r: expected a number in \[1e-40, 1e\+40\] \(mm/s\^n\)\^-2, got 1e-300$",
    ),
    (
        "[model]\nsegment_time = 1e5\n" + with_target("cov = 1.0"),
        r"model.segment_time: expected a number in \[0, 3600\] s, got 100000$",
    ),
    ("pause = 1e300\n" + with_target("cov = 1.0"), r"pause: expected a number in \[0, 3600\] s"),
    (
        "[human_line]\nduration = 1e300\n" + with_target("cov = 1.0"),
        r"human_line.duration: expected a number in \[0, 3600\] s, got 1e\+300$",
    ),
    (
        "[human_line]\nsquiggle = 1e300\n" + with_target("cov = 1.0"),
        r"human_line.squiggle: expected a number in \[0, 1e\+06\] px",
    ),
    (
        "[human_line]\npx_mm = 10.0\n" + with_target("cov = 1.0"),
        r"human_line.px_mm: expected a number in \[1e-06, 1\] mm, got 10$",
    ),
    (
        "[minjerk]\nvia_times = [1e300]\n" + with_target("cov = 1.0"),
        r"minjerk.via_times: expected numbers in \[0, 3600\] s, got 1e\+300$",
    ),
    (
        ("[[strokes]]\nkind = 'minjerk'\npoints = [[0.0, 0.0], [1.0, 1.0]]\n"
        "minjerk = { duration = 1e4 }\n"),
        r"strokes\[0\].minjerk.duration: expected a number in \[0, 3600\] s, got 10000$",
    ),
    (
        "[semi_tied]\nh = 1e300\n" + with_target("cov = 1.0"),
        r"semi_tied.h: expected a number in \[1e-12, 1e\+12\] mm\^2, got 1e\+300$",
    ),
    (
        "[semi_tied]\nh = 1.0\nrho = 1e300\n" + with_target("cov = 1.0"),
        r"semi_tied.rho: expected a number in \[0, 1e\+24\] mm\^4",
    ),
    (
        "[semi_tied]\nh = 1.0\nH = [[1e300, 0.0], [0.0, 1.0]]\n" + with_target("cov = 1.0"),
        r"semi_tied.H: expected numbers in \[-1e\+06, 1e\+06\], got 1e\+300$",
    ),
    (
        ("[[strokes]]\nsemi_tied = { h = 1e12, H = [[1e3, 0.0], [0.0, 1.0]] }\n"
        "targets = [{ mean = [0.0, 0.0] }]\n"),
        r"strokes\[0\].semi_tied: expected variances \(eigenvalues\) .*got 1e\+18$",
    ),
    # mixed dimensions across strokes
    (
        (
            "[[strokes]]\ntargets = [{ mean = [0.0, 0.0], cov = 1.0 }]\n"
            "[[strokes]]\ntargets = [{ mean = [0.0, 0.0, 0.0], cov = 1.0 }]\n"
        ),
        r"strokes\[1\]: is 3-D but strokes\[0\] is 2-D",
    ),
]


@pytest.mark.parametrize(("text", "message"), BAD_CASES)
def test_bad_plans_name_the_file_and_key(text, message):
    with pytest.raises(ScenarioError, match=message):
        parse(text)


def test_nan_in_toml_is_refused_everywhere():
    assert math.isnan(tomllib.loads("x = nan")["x"])
    with pytest.raises(
        ScenarioError, match=r"strokes\[0\].targets\[0\].mean\[0\]: expected a finite number"
    ):
        parse("[[strokes]]\ntargets = [{ mean = [nan, 0.0], cov = 1.0 }]\n")


def test_an_overflowing_std_names_the_std_not_a_missing_covariance():
    """std = 1e300 was reported as if no covariance had been given."""
    with pytest.raises(ScenarioError) as info:
        parse("[[strokes]]\ntargets = [{ mean = [0.0, 0.0], std = 1e300 }]\n")
    assert info.value.key == "strokes[0].targets[0].std"
    assert info.value.file == "plan.toml" and info.value.value == 1e300
    assert "no covariance" not in str(info.value)


def test_samples_beyond_the_budget_are_refused_naming_the_setting(monkeypatch):
    from inkarm.core.budget import BudgetError

    text = "samples = 1000000\n" + with_target("cov = 1.0")
    with pytest.raises(BudgetError, match=r"plan.toml: samples: samples per stroke: about 1e\+06 "
                       r"samples, more than the limit of 1e\+04 samples \(raise it with the "
                       r"environment variable INKARM_MAX_SAMPLES\)"):
        parse(text)
    monkeypatch.setenv("INKARM_MAX_SAMPLES", "2e6")
    assert parse(text).samples == 1_000_000  # read; nothing sampled


def test_numbers_at_the_ends_of_the_ranges_are_accepted():
    plan = parse(
        "pause = 3600.0\n[model]\ndt = 0.0001\nd = 1e-6\nsegment_time = 0.001\n"
        "[[strokes]]\ntargets = [{ mean = [-1e6, 1e6], std = [1e-6, 1e-6] }, "
        "{ mean = [0.0, 0.0], cov = 1e12 }]\n"
    )
    assert plan.strokes[0].model["d"] == 1e-6 and plan.pause == 3600.0
