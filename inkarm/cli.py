"""The ``inkarm`` command: a thin layer over the library.

Each sub-command lives in ``inkarm/commands/<name>.py`` and defines ``add_parser(subparsers)``
and ``run(args) -> int``. Errors a user can cause (:class:`inkarm.errors.InkarmError`) are
printed as one line and exit with status 2, never as a traceback.
"""

from __future__ import annotations

import argparse
import gc
import importlib
import os
import pkgutil
import sys
import warnings

import inkarm
from inkarm.errors import InkarmError

# One BLAS thread unless the user says otherwise: inkarm's linear algebra is small (a 7-joint
# arm's kinematics, banded LQT solves) and its parallelism is processes (sweeps, ensembles, their
# workers inherit this), where BLAS threads only compete. Starting OpenBLAS's thread pools was
# most of the CPU of importing NumPy and SciPy (``import numpy, scipy.linalg``: 370 ms of CPU,
# 170 ms with one thread; benchmarks/bench_startup.py). Set before anything imports NumPy.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def command_names() -> dict[str, str]:
    """Each command's name and its module, sorted, without importing any: ``inkarm/commands/
    fit_style.py`` is ``fit-style``."""
    import inkarm.commands as pkg

    return {info.name.replace("_", "-"): f"inkarm.commands.{info.name}"
            for info in sorted(pkgutil.iter_modules(pkg.__path__), key=lambda i: i.name)
            if not info.name.startswith("_")}


class OneLineParser(argparse.ArgumentParser):
    """Usage errors in one line (``inkarm CMD: error: ...``, exit 2), like every other error;
    ``--help`` shows the usage."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The ``inkarm`` parser; with a ``command`` name only that command's sub-parser (what
    ``inkarm draw ...`` parses: every other command's parser would import its module, a
    tenth of a second in all), else all of them."""
    names = command_names()
    modules = [names[command]] if command in names else list(names.values())
    parser = OneLineParser(
        prog="inkarm",
        description="Human-like pen trajectories, drawn by a simulated or real robot arm. "
        "Units: millimetres and seconds.",
    )
    parser.add_argument("--version", action="version", version=f"inkarm {inkarm.__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=OneLineParser)
    for module in map(importlib.import_module, modules):
        p = module.add_parser(sub)
        p.set_defaults(_run=module.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    given = sys.argv[1:] if argv is None else argv
    parser = build_parser(given[0] if given else None)
    args = parser.parse_args(argv)
    if not getattr(args, "_run", None):
        parser.print_help()
        return 0
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        status = _run(args)
    if status in (0, 1):  # after an error the message stands alone; otherwise say what warned
        shown = (w for w in caught if issubclass(w.category, RuntimeWarning | UserWarning))
        for text in dict.fromkeys(f"{w.category.__name__}: {w.message}" for w in shown):
            print(f"inkarm {args.command}: warning: {text}", file=sys.stderr)
    if argv is None:  # the console command: the interpreter's exit would otherwise spend a
        gc.freeze()  # fifth of `inkarm draw`'s CPU collecting objects that die with it anyway
    return status


def _run(args) -> int:
    try:
        return int(args._run(args) or 0)
    except InkarmError as e:
        print(f"inkarm {args.command}: error: {e}", file=sys.stderr)
        return 2
    except RecursionError:
        print(f"inkarm {args.command}: error: the input is nested too deeply", file=sys.stderr)
        return 2
    except BrokenPipeError:
        # The reader of our output went away (``inkarm ... | head``): not an error of ours.
        sys.stderr.close()
        return 0
    except OSError as e:
        where = f"{e.filename}: " if e.filename else ""
        print(f"inkarm {args.command}: error: {where}{e.strerror or e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"inkarm {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
