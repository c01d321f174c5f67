"""The built-in robot profiles, by name, and a user's own by file."""

from __future__ import annotations

from functools import cache
from pathlib import Path

from inkarm.errors import unknown_name
from inkarm.robots.profile import RobotProfile, load_profile

DATA = Path(__file__).parent / "data"
DEFAULT_ROBOT = "iiwa14"


def robot_names() -> tuple[str, ...]:
    """Names of the built-in profiles (``inkarm/robots/data/<name>.toml``)."""
    return tuple(sorted(p.stem for p in DATA.glob("*.toml")))


@cache
def _builtin(name: str) -> RobotProfile:
    return load_profile(DATA / f"{name}.toml")


def load_robot(name_or_path: str | Path = DEFAULT_ROBOT) -> RobotProfile:
    """A built-in profile by name (:func:`robot_names`), or a profile file (a path ending in
    ``.toml``)."""
    text = str(name_or_path)
    if text.endswith(".toml"):
        return load_profile(Path(text))
    if text not in robot_names():
        raise unknown_name("robot", text, robot_names(), key="robot")
    return _builtin(text)
