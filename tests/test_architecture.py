"""The layer contracts of ARCHITECTURE.md (pyproject's [tool.importlinter]) hold, and fail on a
reversed import."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LINT_IMPORTS = Path(sys.executable).with_name("lint-imports")


def lint_imports(package_parent: Path, config: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(package_parent)}
    return subprocess.run([str(LINT_IMPORTS), "--config", str(config), "--no-cache"],
                          cwd=package_parent, env=env, capture_output=True, text=True,
                          timeout=120, check=False)


def test_the_package_keeps_its_layer_contracts():
    result = lint_imports(ROOT, ROOT / "pyproject.toml")
    assert result.returncode == 0, result.stdout + result.stderr
    assert "Contracts: 4 kept, 0 broken." in result.stdout


def test_a_reversed_import_breaks_the_layers(tmp_path):
    shutil.copytree(ROOT / "inkarm", tmp_path / "inkarm",
                    ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(ROOT / "pyproject.toml", tmp_path / "pyproject.toml")
    log = tmp_path / "inkarm" / "core" / "log.py"
    log.write_text(log.read_text() + "\nfrom inkarm.jobs import run as _upwards  # noqa\n")
    result = lint_imports(tmp_path, tmp_path / "pyproject.toml")
    assert result.returncode != 0
    assert "Dependencies point down BROKEN" in result.stdout
    assert "inkarm.core.log -> inkarm.jobs.run" in result.stdout
