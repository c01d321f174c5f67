"""Every .npz inkarm reads back is refused in one line naming the file when it is empty,
garbage, pickled, a bare .npy, or carries a version that is not an integer."""

from __future__ import annotations

import numpy as np
import pytest

from inkarm.cli import main
from inkarm.core.log import DrawLog
from inkarm.core.npz import read_npz, scalar_int
from inkarm.core.trajectory import Drawing
from inkarm.errors import InputError
from inkarm.ink.pencil_profile import load_profile
from inkarm.models.primitives import PrimitiveModel


def _files(tmp_path):
    (tmp_path / "empty.npz").write_bytes(b"")
    (tmp_path / "garbage.npz").write_bytes(bytes(range(256)) * 12)
    with open(tmp_path / "truncated.npz", "wb") as f:
        np.savez(f, version=np.array(1), W=np.zeros((40, 40)))
    data = (tmp_path / "truncated.npz").read_bytes()
    (tmp_path / "truncated.npz").write_bytes(data[: len(data) // 2])
    np.savez(tmp_path / "pickled.npz", obj=np.array([{"a": 1}], dtype=object))
    np.save(tmp_path / "bare.npy", np.zeros(3))
    (tmp_path / "bare.npy").rename(tmp_path / "bare.npz")
    return ["empty", "garbage", "truncated", "pickled", "bare"]


@pytest.mark.parametrize("reader", [
    lambda p: read_npz(p, "a thing"), PrimitiveModel.load, load_profile,
    DrawLog.from_npz, Drawing.from_npz])
def test_unreadable_files_are_one_input_error_naming_the_file(tmp_path, reader):
    for name in _files(tmp_path):
        path = tmp_path / f"{name}.npz"
        with pytest.raises(InputError) as info:
            reader(path)
        assert str(path) in str(info.value), (name, str(info.value))


@pytest.mark.parametrize(("value", "ok"), [
    (np.array(3), True), (np.array(3.0), True), (np.array(np.nan), False),
    (np.array(2.5), False), (np.array([1, 2]), False), (np.array("1"), False),
    (np.array(np.inf), False)])
def test_versions_are_whole_finite_scalars(value, ok, tmp_path):
    if ok:
        assert scalar_int({"version": value}, "version", "m.npz") == int(value)
    else:
        with pytest.raises(InputError, match="m.npz: version: expected an integer"):
            scalar_int({"version": value}, "version", "m.npz")


def test_a_model_with_a_nan_version_is_refused_by_the_command(tmp_path, capsys):
    from dataclasses import fields
    arrays = {f.name: np.zeros(2) for f in fields(PrimitiveModel)}
    arrays["version"] = np.array(np.nan)
    np.savez(tmp_path / "m.npz", **arrays)
    assert main(["primitives", "scribble", str(tmp_path / "m.npz"), "--out",
                 str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "version: expected an integer, got nan" in err[0], err
