"""Every reproducer of the hostile-input report: exit 2 with one line naming the input (or an
honest result), within 10 s and under 1 GB of address space, in a forked child."""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SVG = ROOT / "scenarios" / "traces" / "signature.svg"
DEFAULT = (ROOT / "inkarm" / "data" / "default.toml").read_text()
LIMITS = {"timeout_s": 10.0, "memory_bytes": 1_000_000_000}

pytestmark = pytest.mark.fuzz


def _csv(n: int) -> str:
    import numpy as np

    t = np.arange(n) * 0.005
    return "t,x,y\n" + "".join(f"{a:.4f},{50 * np.cos(a):.4f},{20 * np.sin(2 * a):.4f}\n"
                               for a in t)


CASES = {
    "restyle --rate 1e9": (["restyle", str(SVG), "--rate", "1e9", "--out", "o"], {}, "--rate"),
    "descend_s = 1e9": (["draw", "job.toml", "--out", "o", "--quiet"],
                        {"job.toml": DEFAULT + "\n[controller]\ndescend_s = 1e9\n"},
                        "controller.descend_s"),
    "tag --glyphs 100000": (["tag", "--glyphs", "100000", "--out", "o"], {}, "--glyphs"),
    "paper_size_mm = [1e5, 1e5]": (["draw", "job.toml", "--out", "o", "--quiet"],
                                   {"job.toml": DEFAULT + "\n[sim]\npaper_size_mm = [1e5, 1e5]\n"},
                                   "sim.paper_size_mm"),
    "40 px/mm": (["draw", "job.toml", "--out", "o", "--quiet"],
                 {"job.toml": DEFAULT.replace("px_per_mm = 10.0", "px_per_mm = 40.0")},
                 "INKARM_MAX_MEMORY_MB"),
    "analyse 100,000 samples": (["analyse", "big.csv"], {"big.csv": _csv(100_000)},
                                "or use --banded"),
    "analyse 5,000 samples": (["analyse", "mid.csv"], {"mid.csv": _csv(5_000)},
                              "INKARM_MAX_DPPLA_STEPS"),
    "deep TOML": (["draw", "deep.toml", "--out", "o"],
                  {"deep.toml": "a = " + "[" * 100_000 + "]" * 100_000 + "\n"},
                  "nested too deeply"),
    "deep SVG": (["restyle", "deep.svg", "--out", "o"],
                 {"deep.svg": '<svg xmlns="http://www.w3.org/2000/svg">' + "<g>" * 50_000
                  + '<path d="M0 0 L10 10"/>' + "</g>" * 50_000 + "</svg>"}, "deep.svg"),
    "1e300 coordinates": (["analyse", "huge.csv"],
                          {"huge.csv": "t,x,y\n0,0,0\n0.1,1e300,0\n0.2,2,2\n0.3,3,3\n"},
                          "huge.csv:3"),
    "restyle --d 1e-300": (["restyle", str(SVG), "--d", "1e-300", "--out", "o"], {}, "--d"),
    "rotate(1e400)": (["restyle", "rot.svg", "--out", "o"],
                      {"rot.svg": '<svg xmlns="http://www.w3.org/2000/svg"><path '
                       'transform="rotate(1e400)" d="M0 0 L10 10 L20 0"/></svg>'}, "rotate"),
    "brush gamma = 1e300": (["draw", "job.toml", "--out", "o", "--quiet"],
                            {"job.toml": DEFAULT.replace('model = "marker"', 'model = "brush"\n'
                                                         "gamma = 1e300")}, "ink.gamma"),
    "--out ''": (["draw", "--out", ""], {}, "--out"),
    "--fps 0 checked first": (["draw", "--out", "o", "--fps", "0"], {}, "--fps"),
    "unwritable video": (["draw", "--out", "o", "--video", "/dev/null/x.mp4"], {}, "--video"),
    "BOM in TOML is fine": (["draw", "bom.toml", "--check", "--out", "o"],
                            {"bom.toml": "\ufeff" + DEFAULT}, None),
    "carriage return in text": (["write", "ab\rc", "--out", "o"], {}, "carriage return"),
}


@pytest.mark.parametrize("name", list(CASES))
def test_reproducer(run_cli, tmp_path, name):
    argv, files, needle = CASES[name]
    for file, text in files.items():
        (tmp_path / file).write_text(text, encoding="utf-8")
    outcome = run_cli(argv, **LIMITS)
    assert outcome.verdict() is None, f"{outcome.verdict()}\n{outcome.stderr[-1500:]}"
    if needle is None:
        assert outcome.code == 0, outcome.stderr
    else:
        assert outcome.code == 2 and needle in outcome.stderr, outcome.stderr
    assert not (tmp_path / "o").exists()  # refused before any output folder is made
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()


def test_a_diverging_run_leaves_no_mujoco_log_in_the_working_folder(run_cli, tmp_path):
    (tmp_path / "job.toml").write_text(DEFAULT + "\n[robot.gains]\nkp = 1e7\nkd = 0.0\n")
    outcome = run_cli(["draw", "job.toml", "--out", "o", "--quiet"], timeout_s=60.0)
    assert outcome.code == 1, outcome.stderr
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()
    assert '"status": "failed"' in (tmp_path / "o" / "status.json").read_text()
