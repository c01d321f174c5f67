"""Names a package offers but imports on first use (PEP 562): ``import inkarm`` and the
configuration of the LQT stay cheap, and MuJoCo or SciPy load only when a name that needs them
is touched."""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any


def lazy_names(package: str, namespace: dict[str, Any],
               table: dict[str, str]) -> Callable[[str], Any]:
    """A module ``__getattr__`` for ``package`` that imports each name of ``table`` (name ->
    the module defining it) when first asked for and keeps it in ``namespace`` (the package's
    ``globals()``)."""

    def __getattr__(name: str) -> Any:
        if name not in table:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = namespace[name] = getattr(importlib.import_module(table[name]), name)
        return value

    return __getattr__


__all__ = ["lazy_names"]
