"""``inkarm regress``: metrics judged by direction and tolerance, ink compared as ink, the
drawn path, baselines, reports, JUnit XML, and the done-when regressions (a detuned gain, a
changed ink model, a changed LQT parameter), each against a real baseline of a real run."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from inkarm.cli import main
from inkarm.errors import InputError, ScenarioError
from inkarm.jobs.regress import (
    HIGHER,
    LOWER,
    REPORT,
    RULES,
    TARGET,
    Rule,
    check_metric,
    compare,
    path_deviation_mm,
)
from inkarm.jobs.regress.baseline import read_baseline, write_baseline
from inkarm.jobs.regress.ink import compare_ink
from inkarm.jobs.run import run
from inkarm.jobs.scenario import load_scenario
from inkarm.jobs.sweep.design import with_point

QUICK = Path(__file__).parents[2] / "scenarios" / "quick_stroke.toml"


# -- ink compared as ink: closed forms on synthetic pages ---------------------------------------

def _page(*rects, shape=(100, 200)) -> np.ndarray:
    grey = np.full(shape, 255, np.uint8)
    for r0, r1, c0, c1 in rects:
        grey[r0:r1, c0:c1] = 0
    return grey


def test_identical_pages_have_no_missing_or_extra_ink_and_full_overlap():
    page = _page((10, 12, 20, 80))
    diff = compare_ink(page, page.copy(), px_per_mm=4.0)
    assert (diff.missing_mm, diff.extra_mm, diff.iou) == (0.0, 0.0, 1.0)


def test_a_missing_stroke_is_measured_by_its_distance_to_the_remaining_ink():
    # two horizontal strokes 30 rows apart; the new page lacks the lower one
    base = _page((10, 12, 20, 80), (40, 42, 20, 80))
    new = _page((10, 12, 20, 80))
    diff = compare_ink(base, new, px_per_mm=4.0)
    assert diff.missing_mm == pytest.approx((41 - 11) / 4.0)  # row 41 to row 11 = 30 px
    assert diff.extra_mm == 0.0
    assert diff.iou == pytest.approx(0.5)
    # the mean pixel difference would call this page 98 % identical
    assert np.mean(base != new) < 0.02


def test_shifted_ink_is_extra_and_missing_by_the_shift():
    base = _page((10, 11, 20, 80))
    new = _page((13, 14, 20, 80))
    diff = compare_ink(base, new, px_per_mm=10.0)
    assert diff.missing_mm == pytest.approx(0.3) and diff.extra_mm == pytest.approx(0.3)
    assert diff.iou == 0.0


def test_a_blank_new_page_misses_everything_by_a_page_diagonal():
    base = _page((10, 11, 20, 80))
    diff = compare_ink(base, _page(), px_per_mm=2.0)
    assert diff.missing_mm == pytest.approx(math.hypot(100, 200) / 2.0)
    assert compare_ink(_page(), _page(), 2.0).iou == 1.0


def test_pages_of_different_sizes_are_refused_by_name():
    with pytest.raises(InputError, match="differ in size"):
        compare_ink(_page(), _page(shape=(100, 201)), 4.0)


def test_path_deviation_is_the_hausdorff_distance_of_the_pen_down_paths():
    t = np.linspace(0.0, 20.0, 41)
    line = np.column_stack([t, np.zeros_like(t)])
    down = np.ones(len(t), bool)
    assert path_deviation_mm(line, down, line, down) == 0.0
    assert path_deviation_mm(line, down, line + [0.0, 0.25], down) == pytest.approx(0.25)
    longer = np.column_stack([np.linspace(0, 23, 47), np.zeros(47)])
    assert path_deviation_mm(line, down, longer, np.ones(47, bool)) == pytest.approx(3.0)
    # pen-up rows do not count, however far they go
    travel = line.copy()
    travel[:5] += [0.0, 50.0]
    lifted = down.copy()
    lifted[:5] = False
    assert path_deviation_mm(line[5:], down[5:], travel, lifted) == 0.0


# -- metrics judged by direction ---------------------------------------------------------------

def test_a_metric_fails_only_when_worse_beyond_its_tolerance():
    lower = Rule(LOWER, 0.1, "mm")
    assert not check_metric("e", 1.0, 0.5, lower, 0.1).regressed  # better
    assert not check_metric("e", 1.0, 1.09, lower, 0.1).regressed  # worse, within
    worse = check_metric("e", 1.0, 1.25, lower, 0.1)
    assert worse.regressed and worse.worse_by == pytest.approx(0.25)
    assert "e got worse by 0.25 mm (1 -> 1.25 mm; tolerance 0.1 mm)" == worse.describe()
    higher = Rule(HIGHER, 0.05, "rad")
    assert check_metric("m", 0.3, 0.2, higher, 0.05).regressed
    assert not check_metric("m", 0.3, 0.9, higher, 0.05).regressed
    target = Rule(TARGET, 0.02, "N")
    assert not check_metric("f", 1.05, 0.97, target, 0.02, set_point=1.0).regressed
    assert check_metric("f", 1.0, 0.95, target, 0.02, set_point=1.0).regressed
    assert check_metric("r", 50.0, 1.0, Rule(REPORT, 0.0, ""), 0.0).worse_by is None


def test_an_undefined_metric_fails_against_a_defined_baseline_only():
    rule = RULES["tracking_rms_mm"]
    assert check_metric("tracking_rms_mm", 0.1, None, rule, 0.02).regressed
    assert "undefined now" in check_metric("tracking_rms_mm", 0.1, None, rule, 0.02).describe()
    assert not check_metric("tracking_rms_mm", None, 0.3, rule, 0.02).regressed


def test_the_realtime_factor_is_reported_never_gated():
    assert RULES["realtime_factor"].direction == REPORT


# -- real runs against a real baseline ---------------------------------------------------------


@pytest.fixture(scope="module")
def quick_baseline(tmp_path_factory):
    """The quick scenario's run and a baseline made of it in a temporary folder."""
    scenario = load_scenario(QUICK)
    result = run(scenario)
    folder = write_baseline(result, tmp_path_factory.mktemp("baselines") / "quick_stroke")
    return scenario, result, read_baseline(folder, tuple(RULES))


@pytest.mark.sim
def test_runs_are_deterministic_and_pass_against_their_own_baseline(quick_baseline):
    scenario, first, baseline = quick_baseline
    second = run(scenario)
    for key, value in first.metrics.items():
        if key != "realtime_factor":
            assert second.metrics[key] == value, key
    c = compare(second, baseline)
    assert c.passed and c.failure_message() == ""
    gated = [m for m in c.checks if m.gated]
    assert gated and all(m.worse_by == 0.0 for m in gated)  # not merely within tolerance
    assert {m.name for m in c.checks} >= set(RULES)


def _regressions(scenario, overrides, baseline):
    c = compare(run(with_point(scenario, overrides)), baseline)
    assert not c.passed
    return c, {m.name: m for m in c.regressions}


DETUNE = 0.8  # the drives' stiffness 20 % low: the drawing finishes (ok or degraded), worse


def _detuned_kp(scenario) -> list[float]:
    """The joint drives' stiffness, detuned by :data:`DETUNE` (far lower, and the watchdogs end
    the run before the pen comes down: nothing to measure but the fault)."""
    return [float(k) * DETUNE for k in scenario.robot.gains.kp]


@pytest.mark.sim
def test_a_detuned_gain_fails_naming_the_metric_and_the_amount(quick_baseline):
    scenario, _, baseline = quick_baseline
    c, worse = _regressions(scenario, {"robot.gains.kp": _detuned_kp(scenario)}, baseline)
    assert "tracking_rms_mm" in worse  # measured whether the run ended ok or degraded
    m = worse["tracking_rms_mm"]
    assert m.worse_by == pytest.approx(m.new - m.baseline) and m.worse_by > m.tolerance
    assert f"tracking_rms_mm got worse by {m.worse_by:.4g} mm" in c.failure_message()


@pytest.mark.sim
def test_a_changed_ink_model_fails_on_the_ink_not_on_the_tracking(quick_baseline):
    scenario, _, baseline = quick_baseline
    c, worse = _regressions(scenario, {"ink.model": "pencil"}, baseline)
    assert not {"tracking_rms_mm", "tracking_max_mm", "path_deviation_mm"} & set(worse)
    assert {"ink_iou", "ink_extra_mm"} & set(worse) or "ink_missing_mm" in worse
    for m in worse.values():
        assert f"{m.name} got worse by {m.worse_by:.4g}" in c.failure_message()


@pytest.mark.sim
def test_a_changed_lqt_parameter_fails_naming_the_metric_and_the_amount(quick_baseline):
    scenario, _, baseline = quick_baseline
    # d = 1 mm instead of 5 mm: a control weight 625 x larger for the 4th-order LQT (R = I /
    # (omega^n d)^2), the stroke passes its targets differently: another path, drawn well
    c, worse = _regressions(scenario, {"source.plan.model.d": 1.0}, baseline)
    assert "path_deviation_mm" in worse
    m = worse["path_deviation_mm"]
    assert m.baseline == 0.0 and m.worse_by == m.new > m.tolerance
    assert f"path_deviation_mm got worse by {m.worse_by:.4g} mm" in c.failure_message()
    # the scenario itself was not changed by the override
    assert compare(run(scenario), baseline).passed


@pytest.mark.sim
def test_a_run_that_did_not_finish_fails_with_its_status_and_reason(quick_baseline):
    scenario, _, baseline = quick_baseline
    diverging = with_point(scenario, {"robot.gains.kp": 1e7, "robot.gains.kd": 0.0})
    result = run(diverging)
    c = compare(result, baseline)
    assert result.status != "ok" and not c.passed and c.status == result.status
    assert c.failure_message().startswith(f"the run {result.status}: {result.reason}")
    if not result.metrics:  # nothing measured: the status is the whole verdict
        assert not c.checks


@pytest.mark.sim
def test_tolerances_of_a_baseline_replace_the_defaults(quick_baseline, tmp_path):
    scenario, result, baseline = quick_baseline
    folder = write_baseline(result, tmp_path / "quick_stroke")
    (folder / "tolerances.toml").write_text("tracking_rms_mm = 100.0\ntracking_max_mm = 100.0\n"
                                            "ink_extra_mm = 100.0\nink_missing_mm = 100.0\n"
                                            "ink_iou = 1.0\npath_deviation_mm = 100.0\n"
                                            "ink_chamfer_mm = 100.0\ncontact_force_std_n = 9.0\n"
                                            "contact_force_mean_n = 9.0\ngap_mm = 100.0\n")
    loose = read_baseline(folder, tuple(RULES))
    assert loose.tolerances["tracking_rms_mm"] == 100.0
    replanned = run(with_point(scenario, {"source.plan.model.d": 1.0}))
    assert replanned.ok and not compare(replanned, baseline).passed
    assert compare(replanned, loose).passed
    write_baseline(result, folder)  # --update keeps the hand-written tolerances
    assert (folder / "tolerances.toml").is_file()
    (folder / "tolerances.toml").write_text("tracking_rms = 0.1\n")
    with pytest.raises(ScenarioError, match="did you mean 'tracking_rms_mm'"):
        read_baseline(folder, tuple(RULES))
    (folder / "tolerances.toml").write_text("tracking_rms_mm = -1\n")
    with pytest.raises(ScenarioError, match="tracking_rms_mm: expected a number >= 0"):
        read_baseline(folder, tuple(RULES))


def test_a_missing_or_damaged_baseline_is_named(tmp_path):
    with pytest.raises(InputError, match="no baseline in .*--update"):
        read_baseline(tmp_path)
    (tmp_path / "baseline.json").write_text("{")
    with pytest.raises(InputError, match="damaged baseline"):
        read_baseline(tmp_path)


# -- the command ---------------------------------------------------------------------------------

def _scenario_copy(folder: Path, replace: tuple[str, str] = ("", "")) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / QUICK.name
    text = QUICK.read_text()
    if replace[0]:
        assert replace[0] in text
        text = text.replace(*replace)
    path.write_text(text)
    return path


@pytest.mark.sim
def test_cli_update_compare_junit_report_and_a_regression(tmp_path, capsys):
    good = _scenario_copy(tmp_path / "good")
    baselines = tmp_path / "bl"
    assert main(["regress", str(good), "--baselines", str(baselines), "--update"]) == 0
    assert "new baseline quick_stroke" in capsys.readouterr().out
    assert sorted(p.name for p in (baselines / "quick_stroke").iterdir()) == [
        "baseline.json", "canvas.png", "metrics.json", "path.npz"]
    assert main(["regress", str(good), "--baselines", str(baselines), "--update"]) == 0
    assert "updated quick_stroke: no metric changed" in capsys.readouterr().out

    assert main(["regress", str(good), "--baselines", str(baselines)]) == 0
    assert "PASS quick_stroke" in capsys.readouterr().out

    changed = _scenario_copy(tmp_path / "changed", ("d = 5.0", "d = 1.0"))  # the LQT's d
    junit, report = tmp_path / "regress.xml", tmp_path / "report"
    code = main(["regress", str(changed), "--baselines", str(baselines), "--junit", str(junit),
                 "--report", str(report)])
    out = capsys.readouterr().out
    assert code == 1 and "FAIL quick_stroke" in out and "path_deviation_mm got worse by" in out
    assert "0 of 1 scenarios passed; regressions in quick_stroke" in out
    case = ET.parse(junit).getroot().find("testcase")
    props = {p.get("name"): p.get("value") for p in case.iter("property")}
    assert float(props["path_deviation_mm"]) > float(props["path_deviation_mm.baseline"]) == 0
    assert props["tracking_rms_mm.tolerance"] == "0.02" and "realtime_factor.tolerance" not in props
    assert props["status"] == "ok" and "tracking_rms_mm.baseline" in props
    assert "path_deviation_mm" in case.find("failure").text
    text = (report / "report.md").read_text()
    assert "## quick_stroke: FAIL" in text and "![quick_stroke" in text
    assert (report / "quick_stroke.png").stat().st_size > 1000

    assert main(["regress", str(changed), "--baselines", str(baselines), "--update"]) == 0
    out = capsys.readouterr().out
    assert "updated quick_stroke:" in out
    assert "path_deviation_mm: 0 -> " in out and "(worse beyond tolerance)" in out
    assert main(["regress", str(changed), "--baselines", str(baselines)]) == 0


def test_cli_errors_name_the_path(tmp_path, capsys):
    assert main(["regress", str(tmp_path / "nope.toml")]) == 2
    assert "nope.toml: no such scenario file or folder" in capsys.readouterr().err
    _scenario_copy(tmp_path / "s")
    assert main(["regress", str(tmp_path / "s")]) == 2
    assert "no scenario with a baseline" in capsys.readouterr().err
    assert main(["regress", str(tmp_path / "s" / QUICK.name)]) == 2
    assert "has no baseline" in capsys.readouterr().err
    assert main(["regress", str(tmp_path / "s"), "--junit", str(tmp_path / "no" / "x.xml")]) == 2
    assert "--junit" in capsys.readouterr().err
