"""What every ``inkarm emulate DEVICE`` does once its emulator is built: serve it on its
pseudo-terminal until Ctrl-C (or SIGTERM), then stop it and keep its ink."""

from __future__ import annotations

import signal
import sys
import time
from collections.abc import Callable
from pathlib import Path

from inkarm.errors import InputError


def _interrupt(signum, frame):
    raise KeyboardInterrupt


def check_png(out: str | None) -> None:
    """Refuse an ``--out`` that does not name a .png file, before the emulator is built."""
    if out is not None and Path(out).suffix.lower() != ".png":
        raise InputError(f"{out}: expected a .png file name", key="--out", value=out)


def serve(emulator, banner: Callable[[str], str], out: str | None = None) -> None:
    """Start ``emulator``, print ``banner(port)`` and then the port alone (the last line of
    stdout, for scripts), run until Ctrl-C or SIGTERM, stop it, and write its ``canvas`` (if it
    has one) to the PNG ``out``."""
    signal.signal(signal.SIGTERM, _interrupt)  # `kill` stops it as Ctrl-C does
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:  # started in the background by a shell
        signal.signal(signal.SIGINT, _interrupt)
    port = emulator.start()
    print(banner(port), flush=True)
    print(port, flush=True)
    try:
        while emulator.running:
            time.sleep(0.2)
    except KeyboardInterrupt:
        pass
    finally:
        emulator.stop()
        canvas = getattr(emulator, "canvas", None)
        if out is not None and canvas is not None:
            print(f"canvas: {canvas.to_png(out)}", file=sys.stderr)
