"""Profiles kept as TOML files (a plotter's pen profiles, the AxiDraw's): the built-ins are the
``*.toml`` files of one folder, named by their stem; any other file is given by its path
(ending in ``.toml``). An unknown name is refused naming the closest built-in (``--profile``)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

from inkarm.errors import unknown_name
from inkarm.io.toml import load_toml

T = TypeVar("T")


def builtin_names(folder: Path) -> tuple[str, ...]:
    """The built-in profiles in ``folder``: its ``*.toml`` files' stems, sorted."""
    return tuple(sorted(p.stem for p in folder.glob("*.toml")))


def load_named(ref: str | Path, folder: Path, what: str,
               parse: Callable[[dict, str, str], T]) -> T:
    """The profile ``ref``: a built-in of ``folder`` by name, or a file by its path (ending in
    ``.toml``), read and checked by ``parse(data, source, name)`` (``name``: the file's stem);
    ``what`` names the kind in errors (``"pen profile"``)."""
    ref = str(ref)
    if ref.endswith(".toml"):
        path = Path(ref)
    else:
        if ref not in builtin_names(folder):
            raise unknown_name(what, ref, builtin_names(folder), key="--profile")
        path = folder / f"{ref}.toml"
    return parse(load_toml(path, what), str(path), path.stem)


__all__ = ["builtin_names", "load_named"]
