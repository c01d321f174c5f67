"""The alternating blocks every benchmark's ratio is taken on (benchmarks/blocks.py)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

spec = importlib.util.spec_from_file_location(
    "blocks", Path(__file__).resolve().parents[1] / "benchmarks" / "blocks.py")
blocks = importlib.util.module_from_spec(spec)
sys.modules.setdefault("blocks", blocks)  # (its dataclass looks its module up)
spec.loader.exec_module(blocks)


def test_cases_alternate_block_by_block_and_ratios_are_of_medians():
    calls = []
    times = {"a": iter([1.0, 9.0, 1.0, 2.0, 2.0, 2.0]), "b": iter([1.0, 1.0, 1.0, 1.0, 1.0, 1.0])}

    def case(name):
        def run():
            calls.append(name)
            return next(times[name])
        return run

    result = blocks.interleave({"a": case("a"), "b": case("b")}, blocks=3, repeats=2, warmup=0,
                               clock=None)
    assert calls == ["a", "a", "b", "b"] * 3  # block k of every case before block k + 1
    assert result.times["a"] == [5.0, 1.5, 2.0]  # each block: the median of its calls
    assert result.median("a") == 2.0 and result.ratio("a", "b") == 2.0  # one bad block ignored
    assert result.spread("a") == pytest.approx(5.0 / 1.5)
    assert "Load average (1 min)" in result.load_line()


def test_bad_counts_are_refused():
    with pytest.raises(ValueError, match="blocks and repeats must be >= 1"):
        blocks.interleave({"a": lambda: None}, blocks=0)
