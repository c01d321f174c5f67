"""Reading ``.npz`` files that may be anything: every file inkarm reads back (models, pencil
profiles, logs, drawings) is refused in one line naming it when it is empty, truncated, not a
zip, holds pickled objects, or its arrays cannot be read; never a traceback from inside NumPy
or zipfile."""

from __future__ import annotations

import math
import zipfile
import zlib
from pathlib import Path

import numpy as np

from inkarm.errors import InputError

_UNREADABLE = (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile, zlib.error)


def read_npz(path: str | Path, what: str) -> dict[str, np.ndarray]:
    """Every array of the ``.npz`` file at ``path`` (read whole, without pickles); ``what``
    names the kind of file in the error ("a primitives model")."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"no such {what.split(' ', 1)[-1]} file (.npz)", file=str(path))
    try:
        data = np.load(path, allow_pickle=False)
        if not isinstance(data, np.lib.npyio.NpzFile):  # a bare .npy array under another name
            raise InputError(f"not {what} (.npz): a single array, not an archive of arrays",
                             file=str(path))
        with data:
            return {key: data[key] for key in data.files}
    except _UNREADABLE as e:
        if isinstance(e, InputError):
            raise
        reason = str(e).split(".")[0] or type(e).__name__
        raise InputError(f"not {what} (.npz): {reason}", file=str(path)) from None


def scalar_int(arrays: dict[str, np.ndarray], key: str, path: str | Path) -> int:
    """The integer scalar ``arrays[key]`` (a version, a count), or an InputError naming the file
    and key: missing, not a scalar, not a finite whole number."""
    if key not in arrays:
        raise InputError("missing field", file=str(path), key=key)
    value = arrays[key]
    try:
        number = float(value) if value.shape == () and value.dtype.kind in "biuf" else math.nan
    except (TypeError, ValueError):
        number = math.nan
    if not (math.isfinite(number) and number == int(number)):
        got = (repr(value.item()) if value.shape == () else
               f"an array of shape {value.shape} ({value.dtype})")
        raise InputError(f"expected an integer, got {got}", file=str(path), key=key)
    return int(number)
