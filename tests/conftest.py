"""Test-wide settings: headless plotting and offscreen GL chosen before MuJoCo is imported, and
a configuration folder of each test's own (a calibration written or read as "auto" never
touches the user's ~/.config/inkarm)."""

import os

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")
os.environ.setdefault("MUJOCO_GL", "egl")


@pytest.fixture(autouse=True)
def _own_config_dir(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("INKARM_CONFIG_DIR", str(tmp_path_factory.mktemp("config")))
