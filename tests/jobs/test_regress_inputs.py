"""`inkarm regress` trusts no input it compares with and writes nowhere it was not asked to:
damaged baselines are refused naming the file and the metric, and `--junit` never replaces a
scenario, a baseline, a device or a link loop (reproducers of the hostile-input campaign)."""

from __future__ import annotations

import json
import os
import re
import shutil
from pathlib import Path

import pytest

from inkarm.cli import main

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def suite(tmp_path):
    """A copy of the quick stroke and its baseline: (scenario file, baseline folder)."""
    shutil.copy(ROOT / "scenarios" / "quick_stroke.toml", tmp_path / "quick_stroke.toml")
    shutil.copytree(ROOT / "scenarios" / "baselines" / "quick_stroke",
                    tmp_path / "baselines" / "quick_stroke")
    return tmp_path / "quick_stroke.toml", tmp_path / "baselines" / "quick_stroke"


@pytest.mark.sim
@pytest.mark.parametrize("metrics, message", [
    ("{}", (r"metrics.json: no tracking_rms_mm, tracking_max_mm, ink_chamfer_mm, gap_mm, "
           r"contact_force_mean_n, contact_force_std_n, joint_limit_margin_rad: every baseline "
           r"records them \(null where not sensed\), so they would pass unchecked")),
    (('{"tracking_rms_mm": 0.1, "tracking_max_mm": 0.2, "ink_chamfer_mm": 0.1, "gap_mm": 0, '
     '"contact_force_std_n": 0.02, "joint_limit_margin_rad": 0.3}'),
     r"no contact_force_mean_n: every baseline records it"),
    ("[]", r"metrics.json: expected a table of metric names to numbers, got list"),
    ('{"tracking_rms_mm": NaN}', (r"metrics.json: tracking_rms_mm: metric 'tracking_rms_mm' is "
                                 r"nan: expected a finite number")),
    ('{"tracking_rms_mm": "small"}', (r"metric 'tracking_rms_mm' is 'small': expected a finite "
                                     r"number")),
])
def test_a_damaged_baseline_is_refused_naming_the_file_and_metric(suite, capsys, metrics,
                                                                 message):
    scenario, baseline = suite
    (baseline / "metrics.json").write_text(metrics)
    assert main(["regress", str(scenario)]) == 2
    err = capsys.readouterr().err
    assert "PASS" not in err and len(err.strip().splitlines()) == 1
    assert re.search(message, err), err


@pytest.mark.parametrize(("name", "edit", "message"), [
    ("baseline.json", lambda d: d | {"versions": 0}, "versions (a table of texts)"),
    ("baseline.json", lambda d: d | {"status": [1]}, "must hold a status (text)"),
    ("path.npz", None, "path.npz: not a baseline's path (.npz)"),
    ("canvas.png", None, "damaged baseline in"),
])
def test_a_damaged_baseline_file_is_refused_naming_it(suite, capsys, name, edit, message):
    """Reproducers of the fuzz campaign: a marker whose versions are not a table, an empty
    path.npz and an empty canvas.png were tracebacks."""
    scenario, baseline = suite
    path = baseline / name
    if edit is None:
        path.write_bytes(b"")
    else:
        path.write_text(json.dumps(edit(json.loads(path.read_text()))))
    assert main(["regress", str(scenario)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err


def test_junit_never_replaces_an_input_a_device_or_a_link_loop(suite, tmp_path, capsys):
    scenario, baseline = suite
    before = scenario.read_text()
    loop = tmp_path / "loop.xml"
    os.symlink(loop, loop)
    cases = [
        (str(loop), "is a link that leads nowhere or in a loop"),
        ("/dev/null", "expected a JUnit XML file name (.xml)"),
        (str(baseline / "metrics.json"), "expected a JUnit XML file name (.xml)"),
    ]
    fifo = tmp_path / "pipe.xml"
    os.mkfifo(fifo)
    cases.append((str(fifo), "exists and is not a regular file"))
    named_input = tmp_path / "quick_stroke.xml"  # an input of the run, under the .xml name
    named_input.symlink_to(scenario)
    cases.append((str(named_input), "is the input"))
    for target, words in cases:
        assert main(["regress", str(scenario), "--junit", target]) == 2, target
        err = capsys.readouterr().err
        assert "--junit" in err and words in err, err
    assert scenario.read_text() == before
    assert json.loads((baseline / "metrics.json").read_text())["tracking_rms_mm"] >= 0
