"""Test-wide settings: headless plotting and offscreen GL chosen before MuJoCo is imported."""

import os

os.environ.setdefault("MPLBACKEND", "Agg")
os.environ.setdefault("MUJOCO_GL", "egl")
