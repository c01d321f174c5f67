"""Hostile input, round 3, the smaller findings: an empty --out, key suggestions that find the
key a user wrote without its unit, and help texts that name the papers and commands that
exist."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from inkarm.cli import main
from inkarm.errors import closest

ROOT = Path(__file__).parents[2]
QUICK = ROOT / "scenarios" / "quick_stroke.toml"


@pytest.mark.parametrize("args", [
    ["write", "hi"], ["tag", "--seed", "1"], ["plan", str(ROOT / "scenarios" / "plans")],
    ["restyle", "x.csv"], ["analyse", "x.csv"], ["pencil", "show", "HB"],
    ["pencil", "extract", "scan.png"], ["primitives", "learn", "letter:a"],
    ["primitives", "scribble", "m.npz"],
])
def test_an_empty_out_is_refused_not_the_working_directory(args, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exit_:  # argparse's usage error
        main([*args, "--out", ""])
    assert exit_.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--out" in err[0] and "empty string" in err[0], err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(("name", "expected"), [
    ("force_gain", "force_gain_mm_per_ns"),  # written without its unit
    ("forse_n", "force_n"),
    ("force", "force_n"),  # the shortest key it begins
    ("zzz", None),
])
def test_the_closest_key_prefers_a_key_the_name_begins(name, expected):
    keys = ["force_n", "force_gain_mm_per_ns", "force_filter_s", "force_limit_n", "hover_mm"]
    assert closest(name, keys) == expected


def test_a_scenario_key_without_its_unit_gets_the_key_with_it(tmp_path, capsys):
    text = QUICK.read_text().replace("[controller]\n", "[controller]\nforce_gain = 3\n", 1)
    scenario = tmp_path / "s.toml"
    scenario.write_text(text)
    assert main(["draw", str(scenario), "--out", str(tmp_path / "out")]) == 2
    assert "did you mean 'force_gain_mm_per_ns'" in capsys.readouterr().err


def _helps():
    from inkarm.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if a.choices and isinstance(a.choices, dict))
    yield "inkarm", parser.format_help()
    for name, p in sub.choices.items():
        yield name, p.format_help()


def test_help_names_papers_not_seed_numbers_and_no_command_that_does_not_exist():
    from inkarm.cli import build_parser

    parser = build_parser()
    commands = set(next(a for a in parser._actions
                        if a.choices and isinstance(a.choices, dict)).choices)
    for name, text in _helps():
        assert not re.search(r"seed 00\d", text), (name, "a user needs the paper's name")
        for cmd in re.findall(r"\binkarm ([a-z](?:[a-z-]*[a-z])?)\b", text):
            assert cmd in commands, (name, f"names `inkarm {cmd}`, which does not exist")


def test_the_readme_links_nothing_outside_the_repository():
    links = re.findall(r"\]\(([^)#]+)\)", (ROOT / "README.md").read_text())
    for link in links:
        if "://" in link:
            continue
        target = (ROOT / link).resolve()
        assert target.is_relative_to(ROOT) and target.exists(), link
