"""A small scenario for tests of placement and plotter keys: one planned stroke (two targets
20 mm apart, 0.3 s), no homing move, and the tables a test adds."""

from __future__ import annotations

import textwrap
from pathlib import Path

ONE_STROKE = """
[source]
kind = "plan"
[source.plan.model]
order = 4
dt = 0.01
d = 5.0
segment_time = 0.3
[[source.plan.strokes]]
name = "stroke"
targets = [{ mean = [0.0, 0.0], cov = 1.0 }, { mean = [20.0, 8.0], cov = 1.0 }]
[controller]
go_home = false
"""


def scenario_file(tmp_path: Path, title: str, tables: str = "", name: str = "s.toml") -> Path:
    """``tmp_path / name``: the one-stroke scenario called ``title``, then ``tables`` (TOML,
    dedented)."""
    path = tmp_path / name
    path.write_text(f'title = "{title}"' + ONE_STROKE + textwrap.dedent(tables))
    return path
