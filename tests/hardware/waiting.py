"""Waiting for something an emulator does in its own thread or process."""

from __future__ import annotations

import time
from collections.abc import Callable


def eventually(check: Callable[[], object], timeout: float = 3.0) -> bool:
    """Whether ``check()`` becomes true within ``timeout`` [s] (polled every 10 ms)."""
    end = time.monotonic() + timeout
    while not check():
        if time.monotonic() > end:
            return False
        time.sleep(0.01)
    return True
