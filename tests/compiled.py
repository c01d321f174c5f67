"""The tests' side of inkarm's optional C extensions: each compiled part's tests compare it with
its Python reference, and skip where it is not built, except where it must be there."""

from __future__ import annotations

import os

import pytest

REQUIRE = "INKARM_REQUIRE_COMPILED"
"""Set to 1 where the extensions must be there (CI: .ci/run): a build that broke fails, not
skips."""


def compiled_or_skip(module, what: str, why: str = "INKARM_COMPILED=0 or not built"):
    """``module`` (an extension's module, None where it is not usable here); None skips the
    test, saying that ``what`` is not usable and ``why``, or fails it with
    INKARM_REQUIRE_COMPILED=1."""
    if module is None:
        message = f"{what} is not usable here ({why})"
        if os.environ.get(REQUIRE) == "1":
            pytest.fail(message)
        pytest.skip(message)
    return module


LOGGED = ("time", "q", "qd", "torque", "tip", "force", "reference", "phase", "stroke")
"""The columns of a DrawLog that a compiled path must give bit for bit."""


def assert_same_log(a, b) -> None:
    """Logs ``a`` and ``b`` (DrawLogs) the same in every :data:`LOGGED` column: dtype, shape and
    bytes."""
    for key in LOGGED:
        x, y = getattr(a, key), getattr(b, key)
        assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes(), key
