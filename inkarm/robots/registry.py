"""The robot profiles by name: the built-in ones, installed plug-ins' and a user's own by file.

The robot registry (:data:`ROBOTS`, ``inkarm.plugins.registry("robot")``) holds the built-in
profiles (``inkarm/robots/data/<name>.toml``, registered by their file names) and, the first
time a name it does not know is asked for, the entry points ``robot.<name>`` of the group
``inkarm.plugins``. A plug-in's entry point names an attribute of its package that is one of:

* a profile file: a :class:`pathlib.Path` (or an :mod:`importlib.resources` file) of a TOML
  profile, usually shipped inside the package (``PROFILE = Path(__file__).parent / "arm.toml"``);
* a :class:`RobotProfile`;
* a callable taking no arguments that returns one of the two.

A scenario then names it like a built-in, ``[robot] name = "<name>"``; ``load_robot`` also
takes ``"package.module:attribute"`` with the same meaning.
"""

from __future__ import annotations

import os
from importlib import resources
from importlib.resources.abc import Traversable
from pathlib import Path
from typing import Any

from inkarm.errors import InkarmError, InputError
from inkarm.plugins import registry
from inkarm.robots.profile import RobotProfile, load_profile

DATA = Path(__file__).parent / "data"
DEFAULT_ROBOT = "iiwa14"

ROBOTS = registry("robot")
for _file in sorted(DATA.glob("*.toml")):
    ROBOTS.register(_file.stem, _file)


def robot_names() -> tuple[str, ...]:
    """Names of the robots: the built-in profiles (``inkarm/robots/data/<name>.toml``) in
    alphabetical order, then the installed plug-ins' (entry points ``robot.<name>``)."""
    return ROBOTS.names()


_LOADED: dict[str, tuple[Any, RobotProfile]] = {}  # name -> (registered item, its profile)


def load_robot(name_or_path: str | Path = DEFAULT_ROBOT) -> RobotProfile:
    """A robot by name (:func:`robot_names`, or ``"package.module:attribute"``), or a profile
    file (a path ending in ``.toml``)."""
    text = str(name_or_path)
    if text.endswith(".toml"):
        return load_profile(Path(text))
    item = ROBOTS.get(text, key="robot")
    loaded = _LOADED.get(text)
    if loaded is not None and loaded[0] is item:
        return loaded[1]
    profile = _profile(text, item)
    _LOADED[text] = (item, profile)
    return profile


def _profile(name: str, item: Any, calls: int = 0) -> RobotProfile:
    """The profile a registered ``item`` stands for (see the module docstring)."""
    if isinstance(item, RobotProfile):
        return item
    if isinstance(item, str | os.PathLike):
        return load_profile(Path(item))
    if isinstance(item, Traversable):
        with resources.as_file(item) as path:
            return load_profile(path)
    if callable(item) and calls == 0:
        try:
            made = item()
        except InkarmError:
            raise
        except Exception as e:  # noqa: BLE001 (a plug-in's bug is named, not a traceback)
            raise InputError(f"robot {name!r}: its plug-in {_named(item)} failed: "
                             f"{type(e).__name__}: {e}", key="robot", value=name) from None
        return _profile(name, made, calls + 1)
    raise InputError(f"robot {name!r} is {_named(item)}; expected a RobotProfile, a profile "
                     f"file (a path) or a callable returning one", key="robot", value=name)


def _named(item: Any) -> str:
    module = getattr(item, "__module__", None)
    qualname = getattr(item, "__qualname__", None)
    return f"{module}:{qualname}" if module and qualname else repr(item)
