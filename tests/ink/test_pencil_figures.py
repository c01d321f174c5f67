"""The pencil figures show the target texture beside the synthesis (issue 25): the scan's
piece cut around the line, the shipped grades' reference scans, and ``inkarm pencil show
--scan`` with its refusals."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from inkarm.errors import InputError
from inkarm.ink.graphite import reference_scan
from inkarm.ink.pencil_extract import extract_profile, upright_line
from inkarm.ink.pencil_profile import resolve_profile, save_profile
from inkarm.plots.pencil import crop_line


def test_crop_line_cuts_the_middle_of_the_line_centred_on_its_darkness():
    scan = np.full((100, 60), 255, np.uint8)
    scan[:, 40:43] = 20  # a line 3 px wide whose centre is column 41
    piece = crop_line(scan, length_mm=5.0, width_mm=1.0, px_per_mm=10.0)
    assert piece.shape == (50, 11)  # 5 mm x (2 * 5 + 1) px
    assert np.array_equal(np.flatnonzero(piece[0] < 255), [4, 5, 6])  # centred
    edge = crop_line(scan[:, 35:], length_mm=20.0, width_mm=5.0, px_per_mm=10.0)
    assert edge.shape == (100, 51) and np.all(edge[:, -10:] == 255)  # paper past the edge


def test_a_shipped_grades_reference_scan_is_the_one_its_profile_came_from():
    profile = resolve_profile("2H")
    back = extract_profile(reference_scan("2H"), px_per_mm=profile.px_per_mm)
    assert np.array_equal(back.glcm, profile.glcm)
    assert np.array_equal(back.full_hist, profile.full_hist)
    with pytest.raises(InputError, match=r"grade: unknown pencil grade '9H'"):
        reference_scan("9H")


def test_show_puts_a_users_scan_beside_the_synthesis_and_names_a_bad_one(tmp_path, capsys):
    from inkarm.cli import main

    scan = upright_line(reference_scan("B", length_mm=10.0)).T.copy()  # a horizontal line
    Image.fromarray(scan).save(tmp_path / "scan.png")
    profile = save_profile(extract_profile(scan), tmp_path / "mine.npz")
    out = tmp_path / "show"
    assert main(["pencil", "show", str(profile), "--scan", str(tmp_path / "scan.png"),
                 "--out", str(out), "--length-mm", "4"]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["line.png", "profile.png"]
    colour = np.zeros((20, 20, 3), np.uint8)
    colour[..., 0] = 200
    Image.fromarray(colour).save(tmp_path / "colour.png")
    capsys.readouterr()
    assert main(["pencil", "show", "HB", "--scan", str(tmp_path / "colour.png"), "--out",
                 str(tmp_path / "other")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "colour.png" in err[0] and "expected a greyscale scan" in err[0]
    assert not (tmp_path / "other").exists()
