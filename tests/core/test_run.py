"""The judge against hand-made metrics: each bound missed alone names itself with its number,
boundary values hold, undefined metrics never pass, what a backend cannot sense is listed as
not judged; Status, Bounds and Metrics as the types the rest of inkarm reads."""

from __future__ import annotations

import dataclasses
import json
import math
import pickle

import pytest

from inkarm.core.run import BOUND_NEEDS, Bounds, Metrics, Senses, Shortfall, Status, judge
from inkarm.errors import InputError

F = 1.0  # the force set point [N]
# Metrics that keep every default bound, with room.
GOOD = {"tracking_rms_mm": 0.1, "tracking_max_mm": 0.4, "ink_chamfer_mm": 0.1, "gap_mm": 0.0,
        "contact_force_mean_n": 1.01, "contact_force_std_n": 0.02, "force_p1_n": 0.95,
        "force_p99_n": 1.05, "joint_limit_margin_rad": 0.3, "realtime_factor": 10.0}
# One miss per bound, alone: the metrics changed, the value judged, and a piece of its sentence.
MISSES = {
    "tracking_rms_mm": ({"tracking_rms_mm": 0.42}, 0.42,
                        "tracking RMS 0.42 mm above tracking_rms_mm = 0.3 mm"),
    "tracking_max_mm": ({"tracking_max_mm": 1.7}, 1.7,
                        "tracking max 1.7 mm above tracking_max_mm = 1 mm"),
    "ink_chamfer_mm": ({"ink_chamfer_mm": 0.35}, 0.35,
                       "ink chamfer 0.35 mm above ink_chamfer_mm = 0.3 mm"),
    "gap_mm": ({"gap_mm": 2.5}, 2.5,
               "gaps above gap_mm = 0 mm: 2.5 mm of the strokes drawn without contact"),
    "force_band_n": ({"force_p1_n": 0.87, "force_p99_n": 1.05}, 0.13,
                     ("force 0.870..1.050 N (1st..99th percentile while drawing) outside "
                      "1 +- 0.1 N (force_band_n)")),
    "force_error_n": ({"contact_force_mean_n": 1.07}, 0.07,
                      ("mean force 1.070 N, 0.07 N from the 1 N set point, above "
                       "force_error_n = 0.05 N")),
}


def test_metrics_within_every_bound_are_ok_with_nothing_unjudged():
    assert judge(GOOD, Bounds(), F) == ([], [])


@pytest.mark.parametrize("bound", list(MISSES))
def test_each_bound_missed_alone_names_itself_with_the_number(bound):
    changed, measured, sentence = MISSES[bound]
    shortfalls, unjudged = judge({**GOOD, **changed}, Bounds(), F)
    assert unjudged == []
    assert [s.bound for s in shortfalls] == [bound]
    s = shortfalls[0]
    assert s.measured == pytest.approx(measured) and s.limit == getattr(Bounds(), bound)
    assert str(s) == s.sentence == sentence


def test_the_force_band_is_judged_on_either_side():
    low, _ = judge({**GOOD, "force_p1_n": 0.89}, Bounds(), F)
    high, _ = judge({**GOOD, "force_p99_n": 1.12}, Bounds(), F)
    assert low[0].measured == pytest.approx(0.11) and high[0].measured == pytest.approx(0.12)
    # the set point is the scenario's, not 1 N
    assert judge({**GOOD, "contact_force_mean_n": 2.0, "force_p1_n": 1.95,
                  "force_p99_n": 2.05}, Bounds(), 2.0) == ([], [])


@pytest.mark.parametrize("bound", [b for b in BOUND_NEEDS if not b.startswith("force")])
def test_a_metric_at_its_bound_holds_and_just_above_misses(bound):
    limit = getattr(Bounds(), bound)
    assert judge({**GOOD, bound: limit}, Bounds(), F)[0] == []
    above = math.nextafter(limit, math.inf)
    assert [s.bound for s in judge({**GOOD, bound: above}, Bounds(), F)[0]] == [bound]


def test_the_force_band_and_mean_at_their_bounds_hold():
    edge = {**GOOD, "force_p1_n": 0.875, "force_p99_n": 1.125, "contact_force_mean_n": 1.0625}
    bounds = Bounds(force_band_n=0.125, force_error_n=0.0625)  # exact in binary
    assert judge(edge, bounds, F) == ([], [])
    assert judge({**edge, "force_p99_n": math.nextafter(1.125, 2.0)}, bounds, F)[0]


def test_a_bound_of_zero_gap_allows_none():
    assert judge({**GOOD, "gap_mm": 0.0}, Bounds(), F)[0] == []
    assert [s.bound for s in judge({**GOOD, "gap_mm": 1e-9}, Bounds(), F)[0]] == ["gap_mm"]


@pytest.mark.parametrize("bound", list(BOUND_NEEDS))
@pytest.mark.parametrize("undefined", [math.nan, None, "absent"])
def test_an_undefined_metric_never_passes(bound, undefined):
    changed, _, _ = MISSES[bound]
    metrics = dict(GOOD)
    for key in changed:
        if undefined == "absent":
            del metrics[key]
        else:
            metrics[key] = undefined
    shortfalls, _ = judge(metrics, Bounds(), F)
    assert [s.bound for s in shortfalls] == [bound]
    assert math.isnan(shortfalls[0].measured)
    assert "undefined, so not within" in shortfalls[0].sentence and bound in shortfalls[0].sentence


def test_no_ink_at_all_misses_the_chamfer():
    shortfalls, _ = judge({**GOOD, "ink_chamfer_mm": math.inf}, Bounds(), F)
    assert [s.bound for s in shortfalls] == ["ink_chamfer_mm"]


def test_what_a_backend_cannot_sense_is_listed_as_unjudged_never_passed():
    servo = Senses.without(force="a Dynamixel arm senses no pen force",
                           contact="the gaps are found from the force")
    # the force and gap metrics are bad (or undefined): not judged, and not shortfalls either
    metrics = {**GOOD, "gap_mm": math.nan, "force_p1_n": math.nan, "force_p99_n": math.nan,
               "contact_force_mean_n": 3.0}
    shortfalls, unjudged = judge(metrics, Bounds(), F, servo)
    assert shortfalls == []
    assert unjudged == ["gap_mm not judged: the gaps are found from the force",
                        "force_band_n not judged: a Dynamixel arm senses no pen force",
                        "force_error_n not judged: a Dynamixel arm senses no pen force"]
    # what it does sense is still judged
    shortfalls, _ = judge({**metrics, "tracking_rms_mm": 0.5}, Bounds(), F, servo)
    assert [s.bound for s in shortfalls] == ["tracking_rms_mm"]


def test_shortfalls_come_in_the_order_of_the_bounds():
    metrics = dict(GOOD)
    for changed, _, _ in MISSES.values():
        metrics.update(changed)
    assert [s.bound for s in judge(metrics, Bounds(), F)[0]] == list(BOUND_NEEDS)
    assert list(BOUND_NEEDS) == [f.name for f in dataclasses.fields(Bounds)]


def test_senses_refuse_an_unknown_quantity():
    with pytest.raises(InputError, match="unknown quantity 'forse'") as e:
        Senses.without(forse="typo")
    assert e.value.choices == ("tip", "ink", "contact", "force")
    assert Senses().senses("force") and not Senses.without(ink="paper").senses("ink")


def test_bounds_default_to_the_readme_and_refuse_bad_values_naming_the_field():
    b = Bounds()
    assert (b.tracking_rms_mm, b.ink_chamfer_mm, b.gap_mm, b.force_band_n) == (0.3, 0.3, 0.0,
                                                                                0.1)
    assert (b.tracking_max_mm, b.force_error_n) == (1.0, 0.05)
    for name, value in [("tracking_rms_mm", -0.1), ("force_band_n", math.nan),
                        ("gap_mm", math.inf), ("ink_chamfer_mm", 1e9)]:
        with pytest.raises(InputError) as e:
            Bounds(**{name: value})
        assert e.value.key == name and "expected a number in [0, " in e.value.message


def test_status_is_a_string_enum():
    assert Status.OK == "ok" and Status("degraded") is Status.DEGRADED
    assert json.dumps({"status": Status.FAILED}) == '{"status": "failed"}'
    assert f"{Status.INTERRUPTED}" == "interrupted" and str(Status.OK) == "ok"
    assert [s.finished for s in Status] == [True, True, False, False]
    assert repr((Status.OK, 0.05)) == "('ok', 0.05)"  # as the package docstring shows it


def test_metrics_read_as_a_mapping_and_write_as_a_dict():
    m = Metrics.of(GOOD)
    assert m["tracking_rms_mm"] == 0.1 and m.tracking_rms_mm == 0.1
    assert m.get("bus_overruns") is None and m.get("nope", 7) == 7 and "bus_overruns" not in m
    assert dict(m) == GOOD and m == GOOD and m.to_dict() == GOOD and len(m) == len(GOOD)
    assert list(m) == list(GOOD)  # the documented order
    assert Metrics() == {} and not Metrics() and Metrics.of(None) == {}
    with pytest.raises(KeyError):
        m["bus_overruns"]
    with pytest.raises(dataclasses.FrozenInstanceError):
        m.gap_mm = 1.0  # read-only
    with pytest.raises(TypeError):
        m["gap_mm"] = 1.0  # a mapping without item assignment
    assert pickle.loads(pickle.dumps(m)) == m
    assert m.replace(bus_overruns=3)["bus_overruns"] == 3
    assert "gap_mm" not in m.replace(gap_mm=None)


def test_metrics_refuse_an_unknown_name_with_the_closest():
    with pytest.raises(InputError, match="did you mean 'tracking_rms_mm'"):
        Metrics.of({"tracking_rms": 0.1})


def test_a_shortfall_is_its_sentence():
    s = Shortfall("gap_mm", 1.0, 0.0, "1 mm drawn without contact")
    assert str(s) == "1 mm drawn without contact"
    assert dataclasses.asdict(s) == {"bound": "gap_mm", "measured": 1.0, "limit": 0.0,
                                     "sentence": "1 mm drawn without contact"}
