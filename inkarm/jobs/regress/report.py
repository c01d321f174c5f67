"""What ``inkarm regress`` hands back: a Markdown report with the ink side by side, and JUnit
XML (one test case per scenario, its metrics as properties) for CI systems."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path

from inkarm.io.outputs import atomic_file, staged
from inkarm.jobs.regress import Comparison

REPORT_FILE = "report.md"


def _cell(value: float | None) -> str:
    return "" if value is None else f"{value:.4g}"


def comparison_markdown(c: Comparison, image: str | None) -> str:
    """The report's section of one scenario: verdict, metric table, ink image."""
    verdict = "PASS" if c.passed else "FAIL"
    lines = [f"## {c.name}: {verdict}", "", f"{c.scenario.title} (`{c.scenario.path}`)", ""]
    if c.status != "ok":
        lines += [f"The run {c.status}: {c.reason}", ""]
    if c.checks:
        lines += ["| metric | baseline | new | worse by | tolerance | verdict |",
                  "|---|---|---|---|---|---|"]
        for m in c.checks:
            unit = f" {m.rule.unit}" if m.rule.unit else ""
            verdict = ("reported" if not m.gated else "**worse**" if m.regressed else "ok")
            tolerance = f"{m.tolerance:g}{unit}" if m.gated else ""
            lines.append(f"| `{m.name}` | {_cell(m.baseline)} | {_cell(m.new)} | "
                         f"{_cell(m.worse_by)} | {tolerance} | {verdict} |")
        lines.append("")
    if image:
        lines += [f"![{c.name}: baseline, new, difference]({image})", ""]
    if c.versions:
        made = ", ".join(f"{k} {v}" for k, v in sorted(c.versions.items()))
        lines += [f"Baseline made with {made}.", ""]
    return "\n".join(lines)


def write_report(comparisons: Sequence[Comparison], out_dir: str | Path) -> Path:
    """Write ``report.md`` and one ``<name>.png`` (baseline, new, difference) per scenario
    into ``out_dir``, through a staged folder. Returns the report's path."""
    from inkarm.plots.figure import save_figure
    from inkarm.plots.regress import plot_ink_comparison

    out = Path(out_dir)
    failed = [c.name for c in comparisons if not c.passed]
    head = [f"# inkarm regress: {len(comparisons) - len(failed)} of {len(comparisons)} passed",
            ""]
    if failed:
        head += [f"Failed: {', '.join(failed)}.", ""]
    head += [("A metric fails only when it gets worse than the baseline by more than its "
             "tolerance; the real-time factor is reported, never gated. Ink: red is baseline "
             "ink the new page lacks, blue is new ink the baseline lacks."), ""]
    sections = []
    with staged(out, marker=REPORT_FILE) as stage:
        for c in comparisons:
            image = None
            if c.base_grey is not None and c.new_grey is not None:
                image = f"{c.name}.png"
                fig = plot_ink_comparison(c.base_grey, c.new_grey, c.px_per_mm,
                                          title=f"{c.name}: {'pass' if c.passed else 'FAIL'}")
                save_figure(fig, stage / image, dpi=110)
            sections.append(comparison_markdown(c, image))
        (stage / REPORT_FILE).write_text("\n".join(head + sections))
    return out / REPORT_FILE


def junit_xml(comparisons: Sequence[Comparison]) -> ET.ElementTree:
    """JUnit XML: a test suite ``inkarm.regress`` with one test case per scenario, each with
    its metrics (``<metric>``, ``<metric>.baseline``, ``<metric>.tolerance``) as properties
    and a ``<failure>`` naming every metric that got worse."""
    failures = sum(not c.passed for c in comparisons)
    suite = ET.Element("testsuite", name="inkarm.regress", tests=str(len(comparisons)),
                       failures=str(failures), errors="0",
                       time=f"{sum(c.wall_s for c in comparisons):.3f}")
    for c in comparisons:
        case = ET.SubElement(suite, "testcase", classname="inkarm.regress", name=c.name,
                             time=f"{c.wall_s:.3f}", file=str(c.scenario.path))
        props = ET.SubElement(case, "properties")
        ET.SubElement(props, "property", name="status", value=c.status)
        for m in c.checks:
            ET.SubElement(props, "property", name=m.name, value=_cell(m.new) or "undefined")
            ET.SubElement(props, "property", name=f"{m.name}.baseline",
                          value=_cell(m.baseline) or "undefined")
            if m.gated:
                ET.SubElement(props, "property", name=f"{m.name}.tolerance",
                              value=f"{m.tolerance:g}")
        if not c.passed:
            message = c.failure_message()
            failure = ET.SubElement(case, "failure", message=message.splitlines()[0],
                                    type="regression" if c.status == "ok" else c.status)
            failure.text = message
    ET.indent(suite)
    return ET.ElementTree(suite)


def write_junit(comparisons: Sequence[Comparison], path: str | Path) -> Path:
    """Write :func:`junit_xml` to ``path`` (atomically: a temporary file renamed; on a failure,
    a full disk included, nothing is left behind and ``path`` is as it was)."""
    path = Path(path)
    with atomic_file(path) as partial:
        junit_xml(comparisons).write(partial, encoding="utf-8", xml_declaration=True)
    return path
