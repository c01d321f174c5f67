"""Pencil profile files: round trip, shipped grades, and every refusal with its message."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from inkarm.errors import InputError
from inkarm.ink import pencil_profile as pp
from inkarm.ink.pencil_profile import (
    GRADES,
    PencilProfile,
    grey_range,
    load_profile,
    resolve_profile,
    save_profile,
)


def _profile(**changes) -> PencilProfile:
    hist = np.zeros(256)
    hist[100:200] = 1.0 / 100
    glcm = np.full((4, 8, 8), 1.0 / 64)
    fields = {"name": "test", "mid_hist": hist, "full_hist": hist, "glcm": glcm,
              "width_mm": 0.5, "px_per_mm": 20.0, "reference_force_n": 1.5,
              "source": "unit test"}
    fields.update(changes)
    return PencilProfile(**fields)


def test_save_and_load_round_trip_every_field(tmp_path):
    profile = _profile()
    path = save_profile(profile, tmp_path / "p.profile")  # any suffix: written as given
    back = load_profile(path)
    assert path.name == "p.profile"
    for key in ("name", "source", "width_mm", "px_per_mm", "reference_force_n"):
        assert getattr(back, key) == getattr(profile, key)
    for key in ("mid_hist", "full_hist", "glcm"):
        assert np.array_equal(getattr(back, key), getattr(profile, key))
    assert back.levels == 8


def test_ranges_leave_out_the_tails():
    hist = np.zeros(256)
    hist[50] = 0.001  # a stray pixel
    hist[100:200] = 0.999 / 100
    assert grey_range(hist) == (100, 199)
    assert grey_range(hist, tail=0.0) == (50, 199)


def test_every_shipped_grade_loads_and_orders_from_hard_to_soft():
    profiles = [resolve_profile(g) for g in GRADES]
    widths = [p.width_mm for p in profiles]
    mean_grey = [np.arange(256) @ p.full_hist for p in profiles]
    assert widths == sorted(widths)  # softer leads draw wider lines ...
    assert all(a > b for a, b in itertools.pairwise(mean_grey))  # ... and strictly darker
    for p in profiles:
        assert "not a real pencil" in p.source
        assert p.levels == 32 and p.glcm.shape == (4, 32, 32)


@pytest.mark.parametrize(("write", "message"), [
    (None, r"no such pencil profile file"),
    (lambda f: f.write_text("hello"), r"not a pencil profile \(.npz\)"),
    (lambda f: np.savez(f, format=np.array("something else")),
     r"not a pencil profile: expected format 'inkarm-pencil-profile'"),
    (lambda f: np.savez(f, format=np.array(pp.FORMAT), version=np.array(99)),
     r"version: pencil profile version 99: this inkarm reads version 1"),
    (lambda f: np.savez(f, format=np.array(pp.FORMAT), version=np.array(1)),
     (r"pencil profile lacks name, mid_hist, full_hist, glcm, offsets, width_mm, px_per_mm, "
      r"reference_force_n")),
])
def test_bad_profile_files_are_refused_naming_the_file(tmp_path, write, message):
    path = tmp_path / "bad.npz"
    if write is not None:
        write(path)
    with pytest.raises(InputError, match=message) as caught:
        load_profile(path)
    assert caught.value.file == str(path)
    assert str(caught.value).startswith(str(path))


def test_a_profile_with_malformed_arrays_is_refused_naming_the_file_and_field(tmp_path):
    path = save_profile(_profile(), tmp_path / "p.npz")
    with np.load(path) as data:
        arrays = dict(data)
    arrays["glcm"] = arrays["glcm"][:, :3, :5]
    np.savez(path, **arrays)
    with pytest.raises(InputError, match=r"p.npz: glcm: a pencil profile expects 4 "
                       r"co-occurrence matrices of L x L probabilities"):
        load_profile(path)
    arrays["glcm"] = np.full((4, 8, 8), 1.0 / 64)
    arrays["offsets"] = np.array([[0, 1]] * 4)
    np.savez(path, **arrays)
    with pytest.raises(InputError, match=r"p.npz: offsets: pencil profile's offsets are not"):
        load_profile(path)


@pytest.mark.parametrize(("changes", "message"), [
    ({"mid_hist": np.ones(256)}, r"mid_hist: a pencil profile expects 256 non-negative"),
    ({"full_hist": np.ones(10) / 10}, r"full_hist: a pencil profile expects 256"),
    ({"glcm": np.ones((4, 1, 1))}, r"glcm: .* \(2 <= L <= 256\), got shape \(4, 1, 1\)"),
    ({"glcm": -np.ones((4, 2, 2)) / 4}, r"glcm: "),
    ({"width_mm": 0.0}, r"width_mm: a pencil profile expects width_mm in \(0, 20\], got 0.0"),
    ({"px_per_mm": float("nan")}, r"px_per_mm: a pencil profile expects px_per_mm in"),
    ({"px_per_mm": 954.0}, r"px_per_mm in \(0.5, 200\], got 954.0"),  # rendered for ever
])
def test_profile_fields_are_checked(changes, message):
    with pytest.raises(InputError, match=message):
        _profile(**changes)


def test_grades_ignore_case_and_an_unknown_one_suggests_the_closest():
    assert resolve_profile("6b") is resolve_profile("6B")
    with pytest.raises(InputError, match=r"grade: unknown pencil grade 'HBB' \(did you mean "
                       r"'HB'\?\); expected one of '2H', 'H', 'F', 'HB', 'B', '3B', '6B', '8B'"):
        resolve_profile("HBB")


def test_a_profile_file_is_reread_when_it_changes(tmp_path):
    path = tmp_path / "mine.npz"
    save_profile(_profile(width_mm=0.5), path)
    assert resolve_profile(str(path)).width_mm == 0.5
    save_profile(_profile(width_mm=0.7), path)
    import os

    os.utime(path, ns=(1, 10**18))  # a different modification time, whatever the clock
    assert resolve_profile(str(path)).width_mm == 0.7
