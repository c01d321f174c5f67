"""Run one `inkarm` command line in a forked child under a memory limit and a timeout.

The parent has imported inkarm and its dependencies once; each case forks (milliseconds), sets
``RLIMIT_AS`` in the child, redirects its standard streams to files and calls
:func:`inkarm.cli.main`. A child that outlives its timeout is killed.
"""

from __future__ import annotations

import gc
import itertools
import math
import os
import resource
import signal
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import pytest

MEMORY_LIMIT_BYTES = 1_500_000_000  # address space a case may add to the forked test process
TIMEOUT_S = 20.0


@dataclass
class Outcome:
    argv: list[str]
    code: int | None  # None: killed (timeout) or died by a signal
    stdout: str
    stderr: str
    seconds: float

    @property
    def timed_out(self) -> bool:
        return self.code is None

    def verdict(self) -> str | None:
        """None when the command behaved (exit 0, or exit 2 with one clean line on stderr),
        else what went wrong."""
        if self.code is None:
            return f"hang or kill after {self.seconds:.1f} s"
        if "Traceback" in self.stderr:
            return f"traceback (exit {self.code})"
        if self.code == 0:
            return None
        lines = [line for line in self.stderr.splitlines() if line.strip()]
        if self.code == 2 and len(lines) == 1 and lines[0].startswith("inkarm "):
            parts = lines[0].split(": ")
            if any(a == b for a, b in itertools.pairwise(parts)):
                return f"a part of the message repeats: {lines[0]}"
            return None
        return f"exit {self.code} with {len(lines)} stderr lines"


def _mapped_bytes() -> int:
    """This process's virtual memory size (VmSize) in bytes."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmSize:"):
            return int(line.split()[1]) * 1024
    return 0


def run_isolated(argv: list[str], cwd: Path, timeout_s: float = TIMEOUT_S,
                 memory_bytes: int = MEMORY_LIMIT_BYTES) -> Outcome:
    """``inkarm ARGV`` in a forked child (see the module docstring)."""
    from inkarm.cli import main

    with tempfile.TemporaryDirectory() as tmp:
        out_path, err_path = Path(tmp) / "out", Path(tmp) / "err"
        start = time.monotonic()
        pid = os.fork()
        if pid == 0:  # the child: never returns
            code = 3
            try:
                # The collector must not walk the test session's inherited objects: touching
                # them copies every page of a long session's heap into the child (seconds, and
                # address space against the limit) before the case has done anything.
                gc.freeze()
                os.chdir(cwd)
                # The limit is on top of what the (forked) test process already maps, so that a
                # long test session's address space does not eat into the case's allowance.
                mapped = _mapped_bytes()
                resource.setrlimit(resource.RLIMIT_AS, (mapped + memory_bytes,) * 2)
                out = os.open(out_path, os.O_WRONLY | os.O_CREAT)
                err = os.open(err_path, os.O_WRONLY | os.O_CREAT)
                os.dup2(out, 1)
                os.dup2(err, 2)
                sys.stdout = open(1, "w", closefd=False)  # noqa: SIM115
                sys.stderr = open(2, "w", closefd=False)  # noqa: SIM115
                code = main(argv)
            except SystemExit as e:
                code = e.code if isinstance(e.code, int) else 2
            except BaseException:  # noqa: BLE001 (report any crash of the child)
                import traceback

                traceback.print_exc()
                code = 3
            finally:
                sys.stdout.flush()
                sys.stderr.flush()
                os._exit(code)
        code = None
        while time.monotonic() - start < timeout_s:
            done, status = os.waitpid(pid, os.WNOHANG)
            if done:
                code = os.waitstatus_to_exitcode(status)
                code = code if code >= 0 else None
                break
            time.sleep(0.005)
        else:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
        return Outcome(argv, code, out_path.read_text(errors="replace"),
                       err_path.read_text(errors="replace"), time.monotonic() - start)


def toml_dumps(data: dict) -> str:
    """TOML text of ``data`` (tables, arrays, numbers including nan and inf, strings)."""
    scalars = {k: v for k, v in data.items() if not isinstance(v, dict)}
    tables = {k: v for k, v in data.items() if isinstance(v, dict)}
    lines = [f"{_key(k)} = {_value(v)}" for k, v in scalars.items()]
    for name, table in tables.items():
        lines += _table(name, table)
    return "\n".join(lines) + "\n"


def _table(path: str, table: dict) -> list[str]:
    lines = [f"[{path}]"]
    lines += [f"{_key(k)} = {_value(v)}" for k, v in table.items() if not isinstance(v, dict)]
    for k, v in table.items():
        if isinstance(v, dict):
            lines += _table(f"{path}.{_key(k)}", v)
    return lines


def _key(k: str) -> str:
    return k if k.replace("_", "").replace("-", "").isalnum() and k.isascii() else _string(k)


def _string(s: str) -> str:
    out = s.replace("\\", "\\\\").replace('"', '\\"')
    out = "".join(c if c.isprintable() else f"\\u{ord(c):04x}" for c in out if ord(c) < 0x10000)
    return f'"{out}"'


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if v in (float("inf"), float("-inf")):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return _string(v)
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_key(k)} = {_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(type(v))


@pytest.fixture
def toml_text():
    """:func:`toml_dumps`, for the fuzz tests."""
    return toml_dumps


@pytest.fixture
def run_cli(tmp_path):
    """``run_cli(argv)`` -> :class:`Outcome` of ``inkarm ARGV`` isolated, in ``tmp_path``."""
    def run(argv, **kw):
        return run_isolated([str(a) for a in argv], tmp_path, **kw)

    return run
