"""The inkarm pytest plugin: scenarios with baselines as test items.

``pytest --inkarm-regress scenarios/`` collects every scenario file ``X.toml`` that has a
baseline in ``baselines/X/`` beside it (or in ``--inkarm-baselines DIR``/X) as one test
item, which re-runs the scenario and compares it with its baseline exactly as
``inkarm regress`` does (:mod:`inkarm.jobs.regress`). A failure names each metric that got
worse, by how much, and its tolerance; the metrics are recorded as the item's user properties
(they land in pytest's ``--junitxml``). Registered as the ``pytest11`` entry point ``inkarm``:
installed with inkarm, inactive without ``--inkarm-regress``. Nothing of inkarm is imported
until a scenario is collected.
"""

from __future__ import annotations

from pathlib import Path

import pytest

MARKER_NAME = "inkarm_scenario"


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("inkarm", "inkarm scenario regression tests")
    group.addoption("--inkarm-regress", action="store_true", default=False,
                    help="collect scenario files (*.toml) that have a baseline as tests that "
                    "re-run them and compare with the baseline")
    group.addoption("--inkarm-baselines", metavar="DIR", default=None,
                    help="baselines live in DIR/<scenario name> (default: the baselines "
                    "folder beside each scenario)")


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", f"{MARKER_NAME}: an inkarm scenario compared with its "
                            "baseline (--inkarm-regress)")


def pytest_collect_file(file_path: Path, parent: pytest.Collector):
    config = parent.config
    if not config.getoption("inkarm_regress") or file_path.suffix != ".toml":
        return None
    from inkarm.jobs.regress.baseline import MARKER, baseline_dir

    folder = baseline_dir(file_path, config.getoption("inkarm_baselines"))
    if not (folder / MARKER).is_file():
        return None
    return ScenarioFile.from_parent(parent, path=file_path)


class ScenarioFile(pytest.File):
    """A scenario file with a baseline: one :class:`ScenarioItem`."""

    def collect(self):
        item = ScenarioItem.from_parent(self, name=self.path.stem)
        item.add_marker(MARKER_NAME)
        yield item


class ScenarioRegression(Exception):
    """A scenario that got worse than its baseline (or whose run did not finish ok)."""

    def __init__(self, comparison):
        super().__init__(comparison.failure_message())
        self.comparison = comparison


class ScenarioItem(pytest.Item):
    """Re-run one scenario and compare it with its baseline."""

    def runtest(self) -> None:
        from inkarm.jobs.regress import regress
        from inkarm.jobs.regress.baseline import baseline_dir
        from inkarm.jobs.scenario import load_scenario

        folder = baseline_dir(self.path, self.config.getoption("inkarm_baselines"))
        comparison = regress(load_scenario(self.path), folder)
        for check in comparison.checks:
            self.user_properties.append((check.name, check.new))
        if not comparison.passed:
            raise ScenarioRegression(comparison)

    def repr_failure(self, excinfo, style=None):
        from inkarm.errors import InkarmError

        error = excinfo.value
        if isinstance(error, ScenarioRegression):
            c = error.comparison
            lines = "\n".join(f"  {line}" for line in c.failure_message().splitlines())
            return f"scenario {c.name} ({self.path}) regressed against its baseline:\n{lines}"
        if isinstance(error, InkarmError):
            return f"scenario {self.name}: {error}"
        return super().repr_failure(excinfo, style=style)

    def reportinfo(self):
        return self.path, None, f"inkarm scenario {self.name}"
