"""Output folders that always describe one run: staged, then moved into place.

A command writes its files into a fresh hidden folder beside ``--out``; only when every file is
complete are they moved into ``--out``, each with an atomic rename (which replaces a planted
symlink itself, never the file it points to). The folder's marker file (``status.json`` for a
drawing run) is removed first and moved in last, so a folder without it is incomplete. Files the
command owns but did not produce this time (a failed run has no ``metrics.json``) are removed, so
no file of an earlier run is left beside a new one. If anything fails before the move (a full
disk, an error, Ctrl-C), ``--out`` is left exactly as it was. A single file is written the
same way (:func:`atomic_file`): complete under a hidden name beside it, then renamed.

A rename works only within one file system, so the staging folder is made on the target's own:
inside ``--out`` when it exists (a mount point, or a link to a folder elsewhere, included),
else beside it. Where a rename still crosses file systems (a single file that is itself a mount
point), the file is copied beside the target and renamed, else copied onto it.
"""

from __future__ import annotations

import errno
import os
import shutil
import tempfile
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

from inkarm.errors import InputError


def out_path(text: str) -> Path:
    """An argparse ``type`` for ``--out``: the path, refusing an empty string (``Path('')``
    would be the working directory, which no user means)."""
    if not text.strip():
        import argparse

        raise argparse.ArgumentTypeError("expected a file or folder name, got an empty string")
    return Path(text)


def check_out_dir(path: str | Path, inputs: Iterable[str | Path] = (),
                  names: Iterable[str] = ()) -> Path:
    """The ``--out`` folder, checked before any work (nothing is created): not empty, not a
    file, its nearest existing ancestor a writable folder, and none of the ``inputs`` at one of
    the file ``names`` the command will write there."""
    text = str(path)
    if not text.strip():
        raise InputError("expected a folder name, got an empty string", key="--out", value=text)
    out = Path(text)
    dangling = next((p for p in (out, *out.parents) if p.is_symlink() and not p.exists()), None)
    if dangling is not None:
        raise InputError(f"{dangling} is a link that leads nowhere or in a loop; expected a "
                         "folder", key="--out", value=text)
    if out.exists() and not out.is_dir():
        raise InputError(f"{out} exists and is not a directory", key="--out", value=text)
    existing = next((p for p in (out, *out.parents) if p.exists()), Path("."))
    if not existing.is_dir() or not os.access(existing, os.W_OK | os.X_OK):
        raise InputError(f"cannot create or write {out}: {existing} is not a writable folder",
                         key="--out", value=text)
    targets = {(out / name).resolve() for name in names}
    for source in inputs:
        if Path(source).resolve() in targets:
            raise InputError(f"{out} holds the input {source}, which this command would "
                             "overwrite; choose another folder", key="--out", value=text)
    return out


def check_out_file(path: str | Path, what: str, suffixes: tuple[str, ...],
                   inputs: Iterable[str | Path] = (), key: str = "--out",
                   probe: bool = False) -> Path:
    """The output file ``key`` (``--out``), checked before any work: a ``what`` file name (not
    empty, not a folder) ending in one of ``suffixes`` (lower case, with the dot), in a writable
    folder; not an existing device, pipe or socket, nor a link that leads nowhere or in a loop
    (replacing it would write where the user did not mean); and none of the ``inputs``, which
    it would overwrite. ``probe``: also make (and remove) a file in its folder, for a command
    that writes the file only when it ends."""
    text = str(path)
    if not text.strip():
        raise InputError("expected a file name, got an empty string", key=key, value=text)
    out = Path(text)
    expected = f"a {what} file name ({' or '.join(suffixes)})"
    if out.is_dir():
        raise InputError(f"{out} is a folder: expected {expected}", key=key, value=text)
    if out.suffix.lower() not in suffixes:
        raise InputError(f"{out}: expected {expected}", key=key, value=text)
    if out.is_symlink() and not out.exists():
        raise InputError(f"{out} is a link that leads nowhere or in a loop; expected {expected}",
                         key=key, value=text)
    if out.exists() and not out.is_file():
        raise InputError(f"{out} exists and is not a regular file (a device, pipe or socket); "
                         f"expected {expected}", key=key, value=text)
    parent = out.absolute().parent
    if not parent.is_dir() or not os.access(parent, os.W_OK | os.X_OK) or (
            probe and not _can_create_in(parent)):
        raise InputError(f"cannot write {out}: {parent} is not a writable folder",
                         key=key, value=text)
    for source in inputs:
        if Path(source).exists() and out.resolve() == Path(source).resolve():
            raise InputError(f"{out} is the input {source}, which this command would overwrite; "
                             "choose another file", key=key, value=text)
    return out


def _can_create_in(folder: Path) -> bool:
    """Whether a file can be made in ``folder`` (a hidden one, removed at once): the only test
    that holds for root and for virtual file systems (/proc), where access() says yes."""
    try:
        fd, name = tempfile.mkstemp(prefix=".inkarm-probe.", dir=folder)
    except OSError:
        return False
    os.close(fd)
    os.unlink(name)
    return True


def _umask() -> int:
    """The process's file-creation mask (read without changing it where Linux allows)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except OSError:
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _stage_dir(out: Path) -> Path:
    """Where to stage files for ``out``: inside it when it is a folder (followed to where a
    link leads: the rename into it must stay on its file system), else in its parent."""
    if out.is_dir():
        return out.resolve()
    parent = out.absolute().parent
    parent.mkdir(parents=True, exist_ok=True)
    return parent.resolve()


def move_into_place(src: Path, dst: Path) -> None:
    """Rename ``src`` to ``dst`` atomically; across file systems (``EXDEV``, or ``EBUSY`` for a
    mount point) copy it to a hidden file beside ``dst`` and rename that, or, if that too
    crosses (``dst`` is itself a mount point), copy it onto ``dst``."""
    try:
        os.replace(src, dst)
        return
    except OSError as e:
        if e.errno not in (errno.EXDEV, errno.EBUSY):
            raise
    fd, name = tempfile.mkstemp(prefix=f".{dst.stem}.", suffix=".partial",
                                dir=dst.absolute().parent)
    os.close(fd)
    beside = Path(name)
    try:
        shutil.copy(src, beside)  # content and mode
        try:
            os.replace(beside, dst)
        except OSError as e:
            if e.errno not in (errno.EXDEV, errno.EBUSY):
                raise
            shutil.copyfile(beside, dst)
    finally:
        beside.unlink(missing_ok=True)
        Path(src).unlink(missing_ok=True)


@contextmanager
def staged(out_dir: str | Path, marker: str | None = None,
           owned: Iterable[str] = ()) -> Iterator[Path]:
    """Yield a fresh staging folder on ``out_dir``'s file system; on a normal exit move its
    files into ``out_dir`` (created if missing), ``marker`` last, and remove the ``owned``
    names that were not produced. On an exception the staging folder is deleted and
    ``out_dir``'s files are untouched."""
    out = Path(out_dir)
    stage = Path(tempfile.mkdtemp(prefix=f".{out.name or 'out'}.", suffix=".partial",
                                  dir=_stage_dir(out)))
    try:
        yield stage
        out.mkdir(exist_ok=True)
        produced = sorted(p.name for p in stage.iterdir())
        if marker is not None:
            (out / marker).unlink(missing_ok=True)
        for name in set(owned) - set(produced):
            (out / name).unlink(missing_ok=True)
        for name in sorted(produced, key=lambda n: n == marker):
            move_into_place(stage / name, out / name)
    finally:
        shutil.rmtree(stage, ignore_errors=True)


@contextmanager
def atomic_file(path: str | Path) -> Iterator[Path]:
    """Yield a hidden path beside ``path`` (same suffix, so writers that add one, like
    ``np.savez``, keep it); on a normal exit rename it to ``path`` atomically; on an exception
    remove it and leave ``path`` as it was."""
    out = Path(path)
    fd, name = tempfile.mkstemp(prefix=f".{out.stem}.", suffix=f".partial{out.suffix}",
                                dir=out.absolute().parent)
    os.fchmod(fd, 0o666 & ~_umask())  # mkstemp's 0600 would make every output private
    os.close(fd)
    staging = Path(name)
    try:
        yield staging
        move_into_place(staging, out)
    finally:
        staging.unlink(missing_ok=True)
