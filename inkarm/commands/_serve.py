"""What every ``inkarm emulate DEVICE`` does once its emulator is built: serve it on its
pseudo-terminal until Ctrl-C (or SIGTERM), then stop it and keep its ink."""

from __future__ import annotations

import signal
import sys
import time
from collections.abc import Callable

from inkarm.io.outputs import atomic_file, check_out_file


def _interrupt(signum, frame):
    raise KeyboardInterrupt


def check_png(out: str | None) -> None:
    """Refuse an ``--out`` that is not a .png file the command can write (a folder, a device,
    a link loop, a folder it cannot create files in), before the emulator is built: the canvas
    is written when the emulator stops, too late to say so."""
    if out is not None:
        check_out_file(out, "PNG", (".png",), probe=True)


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
            with atomic_file(out) as partial:  # a link planted at --out is replaced, not followed
                canvas.to_png(partial)
            print(f"canvas: {out}", file=sys.stderr)
