"""``inkarm regress [SCENARIOS...] [--update] [--junit FILE] [--report DIR]``: re-run scenarios
and compare them with their baselines (:mod:`inkarm.jobs.regress`)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from inkarm.io.outputs import check_out_dir, check_out_file


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "regress",
        help="re-run scenarios and compare them with their baselines (exit 1 on a regression)",
        description="Run every scenario that has a baseline in <its folder>/baselines/<name>/ "
        "and compare metrics, ink and drawn path with it: a metric fails when it gets worse "
        "than the baseline by more than its tolerance. With --update, run them and write "
        "new baselines instead, printing what changed.",
    )
    p.add_argument("scenarios", nargs="*", default=["scenarios"], metavar="SCENARIOS",
                   help="scenario files or folders of them (default: scenarios)")
    p.add_argument("--update", action="store_true",
                   help="write new baselines (for every scenario of a folder) and print what "
                   "changed")
    p.add_argument("--baselines", metavar="DIR", default=None,
                   help="baseline folders live in DIR/<name> (default: the baselines folder "
                   "beside each scenario)")
    p.add_argument("--junit", metavar="FILE.xml", default=None,
                   help="write JUnit XML, one test case per scenario, metrics as properties")
    p.add_argument("--report", metavar="DIR", default=None,
                   help="write report.md with the baseline, new and difference ink per scenario")
    return p


def check_junit_path(path: str, inputs=()) -> Path:
    """``--junit``: an ``.xml`` file in a writable folder, not a device or a link loop, and
    none of the run's ``inputs`` (its scenarios, their baselines), checked before any run."""
    return check_out_file(path, "JUnit XML", (".xml",), inputs=inputs, key="--junit")


def run(args: argparse.Namespace) -> int:
    from inkarm.jobs.regress import find_scenarios
    from inkarm.jobs.scenario import load_scenario

    junit = check_junit_path(args.junit) if args.junit else None  # (before the search)
    report = check_out_dir(args.report) if args.report else None
    pairs = find_scenarios(args.scenarios, args.baselines, update=args.update)
    if junit is not None:  # and not one of the files the run reads
        check_junit_path(args.junit, [path for path, _ in pairs] + [
            file for _, folder in pairs if Path(folder).is_dir() for file in Path(folder).iterdir()])
    scenarios = [(load_scenario(path), folder) for path, folder in pairs]  # all checked first
    if args.update:
        return update(scenarios)
    return compare_all(scenarios, junit, report)


def compare_all(scenarios, junit: Path | None, report: Path | None) -> int:
    from inkarm.jobs.regress import regress

    comparisons = []
    for scenario, folder in scenarios:
        c = regress(scenario, folder)
        comparisons.append(c)
        rtf = next((m.new for m in c.checks if m.name == "realtime_factor"), None)
        speed = f", real-time factor {rtf:.1f}" if rtf is not None else ""
        print(f"{'PASS' if c.passed else 'FAIL'} {c.name} ({c.wall_s:.1f} s{speed})", flush=True)
        for line in c.failure_message().splitlines():
            print(f"    {line}", flush=True)
    if junit is not None:
        from inkarm.jobs.regress.report import write_junit

        print(f"junit: {write_junit(comparisons, junit)}")
    if report is not None:
        from inkarm.jobs.regress.report import write_report

        print(f"report: {write_report(comparisons, report)}")
    failed = [c.name for c in comparisons if not c.passed]
    print(f"{len(comparisons) - len(failed)} of {len(comparisons)} scenarios passed"
          + (f"; regressions in {', '.join(failed)}" if failed else ""))
    return 1 if failed else 0


def update(scenarios) -> int:
    from inkarm.jobs.regress import RULES, compare
    from inkarm.jobs.regress.baseline import (
        MARKER,
        library_versions,
        read_baseline,
        write_baseline,
    )
    from inkarm.jobs.run import run as run_scenario

    versions = library_versions()
    failed = []
    for scenario, folder in scenarios:
        result = run_scenario(scenario)
        name = folder.name
        if not result.ok:
            print(f"inkarm regress: error: {name}: the run {result.status}: {result.reason}; "
                  f"baseline in {folder} left as it was", file=sys.stderr)
            failed.append(name)
            continue
        old = read_baseline(folder, tuple(RULES)) if (folder / MARKER).is_file() else None
        if old is None:
            write_baseline(result, folder)
            print(f"new baseline {name}: {folder}")
            continue
        comparison = compare(result, old, name)
        write_baseline(result, folder)
        changes = [m for m in comparison.checks
                   if m.gated and _fmt(m.new) != _fmt(m.baseline)]
        if not changes:
            print(f"updated {name}: no metric changed")
        else:
            print(f"updated {name}:")
            for m in changes:
                unit = f" {m.rule.unit}" if m.rule.unit else ""
                verdict = " (worse beyond tolerance)" if m.regressed else ""
                print(f"    {m.name}: {_fmt(m.baseline)} -> {_fmt(m.new)}{unit}{verdict}")
        moved = [f"{k} {old.versions.get(k, '?')} -> {v}" for k, v in versions.items()
                 if old.versions.get(k) != v]
        if moved:
            print(f"    versions: {', '.join(moved)}")
    return 1 if failed else 0


def _fmt(value) -> str:
    return "undefined" if value is None else f"{value:.4g}"
