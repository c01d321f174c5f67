"""What a run prints of metrics its backend cannot sense: "not sensed", never "nan" or "inf"."""

from __future__ import annotations

import math

from inkarm.commands.draw import summary_line
from inkarm.core.run import metric_text


def test_metric_text_says_what_a_number_cannot():
    m = {"a": 0.12345, "b": math.nan, "c": math.inf}
    assert metric_text(m, "a") == "0.123 mm"
    assert metric_text(m, "b") == "not sensed"
    assert metric_text(m, "missing") == "not sensed"
    assert metric_text(m, "c") == "nothing to compare"


def test_a_run_without_force_or_ink_sensing_prints_no_nan_or_inf():
    nan = math.nan
    metrics = {"tracking_rms_mm": 0.5, "tracking_max_mm": 1.0, "ink_chamfer_mm": math.inf,
               "gap_mm": nan, "contact_force_mean_n": nan, "contact_force_std_n": nan,
               "force_p1_n": nan, "force_p99_n": nan, "joint_limit_margin_rad": 0.3,
               "realtime_factor": 1.0}
    line = summary_line(metrics)
    assert "nan" not in line and "inf" not in line
    assert "gaps not sensed; force not sensed" in line
    assert "ink chamfer nothing to compare" in line and "tracking RMS 0.500 mm" in line
