"""inkarm's optional C extensions: whether this process may use one.

Each is built by pip from the sources where a C compiler is there (``setup.py``; optional: the
install goes on without one) and has a Python reference that gives the same bits. One is used
only when the environment variable ``INKARM_COMPILED`` is not ``0`` (the switch for comparisons,
for every compiled part at once), and it imports and is of this source (its ``API`` constant:
an extension left from an older checkout is not used until ``pip install -e .`` builds it
again). Why one is not used is logged once at debug level, on the logger of the module that
asked.
"""

from __future__ import annotations

import functools
import importlib
import logging
import os
from collections.abc import Callable
from types import ModuleType

SWITCH = "INKARM_COMPILED"
"""Set to 0 to run every compiled part of inkarm in Python (the same bits)."""


def switched_on() -> bool:
    """False where ``INKARM_COMPILED=0`` asks for the Python arithmetic everywhere."""
    return os.environ.get(SWITCH, "1") != "0"


def extension(name: str, api: int, what: str, log: logging.Logger):
    """The extension module ``name`` (``"inkarm.ink._pen"``) when it imports and its ``API``
    is ``api``; else None, and why, naming ``what`` it is, logged on ``log`` (debug). Callers
    cache the answer (once a process)."""
    try:
        module = importlib.import_module(name)
    except ImportError as error:
        log.debug("%s not used (the extension is not built: %s)", what, error)
        return None
    if getattr(module, "API", None) != api:
        log.debug("%s not used: the extension is of another inkarm (API %s, this is %s): build "
                  "it again (pip install -e .)", what, getattr(module, "API", "none"), api)
        return None
    return module


def loader(name: str, api: int, what: str,
           log: logging.Logger) -> Callable[[], ModuleType | None]:
    """:func:`extension` as a function that looks once a process (its ``cache_clear()``
    looks again)."""
    return functools.cache(lambda: extension(name, api, what, log))


__all__ = ["SWITCH", "extension", "loader", "switched_on"]
