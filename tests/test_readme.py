"""The README's Python quick start runs as written."""

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


@pytest.mark.sim
@pytest.mark.slow
def test_the_readme_python_quick_start_runs(tmp_path, monkeypatch, capsys):
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.DOTALL)
    assert blocks, "the README lost its Python quick start"
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    exec(compile(blocks[0], "README.md", "exec"), namespace)  # noqa: S102 (our own README)
    assert namespace["result"].status == "ok"
    assert namespace["result"].metrics["tracking_rms_mm"] < 0.1
    assert namespace["paths"].shape[0] == 20
    assert namespace["small"].robot.name == "wx250s"
    assert list(tmp_path.iterdir()) == []  # run() wrote nothing
    assert "ok" in capsys.readouterr().out
