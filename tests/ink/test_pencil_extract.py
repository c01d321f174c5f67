"""Extraction of pencil statistics from scans (seed 002 ch. 4.1): the co-occurrence matrices
against brute-force counting, invariance to the line's direction, and every refusal."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from inkarm.errors import InputError
from inkarm.ink.graphite import render_scan
from inkarm.ink.pencil_extract import extract_profile, line_glcm, pair_counts, read_scan
from inkarm.ink.pencil_profile import OFFSETS
from inkarm.ink.pencil_synthesis import glcm_distance
from inkarm.ink.pencil_synthesis import pair_counts as fast_pair_counts


def _brute_counts(level, mask, levels):
    """Eq. 4.1 by loops: each pixel and its neighbour at each offset, both on the line,
    counted both ways."""
    out = np.zeros((len(OFFSETS), levels, levels))
    rows, cols = level.shape
    for k, (dr, dc) in enumerate(OFFSETS):
        for r in range(rows):
            for c in range(cols):
                rr, cc = r + dr, c + dc
                if 0 <= rr < rows and 0 <= cc < cols and mask[r, c] and mask[rr, cc]:
                    out[k, level[r, c], level[rr, cc]] += 1
                    out[k, level[rr, cc], level[r, c]] += 1
    return out


@pytest.mark.parametrize("seed", range(4))
def test_co_occurrence_counts_match_brute_force_counting(seed):
    rng = np.random.default_rng(seed)
    levels = int(rng.integers(2, 7))
    level = rng.integers(0, levels, size=(int(rng.integers(1, 9)), int(rng.integers(1, 9))))
    mask = rng.random(level.shape) < 0.75
    expected = _brute_counts(level, mask, levels)
    assert np.array_equal(pair_counts(level, mask, levels), expected)  # scikit-image
    assert np.array_equal(fast_pair_counts(level, mask, levels), expected)  # the repair's


def test_line_glcm_is_normalised_and_refuses_a_line_without_pairs():
    grey = np.array([[10, 200], [30, 90]], np.uint8)
    glcm = line_glcm(grey, np.ones((2, 2), bool), 4)
    assert np.allclose(glcm.sum(axis=(1, 2)), 1.0)
    with pytest.raises(InputError, match="too thin or broken to pair its pixels"):
        line_glcm(grey, np.array([[True, False], [False, False]]), 4)


@pytest.fixture(scope="module")
def scan_hb():
    return render_scan("HB", length_mm=20.0, rng=np.random.default_rng(7))


def test_statistics_of_a_scan_do_not_depend_on_the_line_direction_or_paper_grey(scan_hb):
    upright = extract_profile(scan_hb)
    across = extract_profile(scan_hb.T.copy())  # a horizontal line: turned upright
    assert np.array_equal(across.full_hist, upright.full_hist)
    assert np.allclose(across.glcm[:2], upright.glcm[:2])  # along and across the line
    # turned by 90 degrees, the transposed scan is the scan mirrored: the diagonals swap
    assert np.allclose(across.glcm[2:], upright.glcm[2:]) or \
        np.allclose(across.glcm[2:], upright.glcm[:1:-1])
    darker_paper = np.round(scan_hb * (230.0 / 246.0)).astype(np.uint8)  # a greyer scanner
    grey = extract_profile(darker_paper)
    assert glcm_distance(grey.glcm, upright.glcm) < 0.2  # re-quantised greys; two scans: ~0.2
    assert abs(grey.width_mm - upright.width_mm) < 0.02


def test_a_tilted_line_is_turned_upright(scan_hb):
    from skimage.transform import rotate

    upright = extract_profile(scan_hb)
    padded = np.pad(scan_hb, ((0, 0), (200, 200)), constant_values=246)
    tilted = np.round(rotate(padded, 20.0, order=0, cval=246, preserve_range=True))
    turned = extract_profile(tilted.astype(np.uint8))
    assert abs(turned.width_mm - upright.width_mm) < 0.05
    assert np.abs(turned.full_hist - upright.full_hist).sum() < 0.3


def test_a_speck_of_dust_away_from_the_line_is_left_out(scan_hb):
    clean = extract_profile(scan_hb)
    dusty = np.pad(scan_hb, ((0, 0), (0, 100)), constant_values=246)
    dusty[100:104, -20:-16] = 0
    assert np.array_equal(extract_profile(dusty).full_hist, clean.full_hist)


@pytest.mark.parametrize(("grey", "kwargs", "message"), [
    (np.zeros((3, 3, 3), np.uint8), {}, r"expected a 2-D grey image, got shape \(3, 3, 3\)"),
    (np.full((40, 40), 30, np.uint8), {}, r"the page is dark \(median grey 30 of 255\)"),
    (np.full((40, 40), 250, np.uint8), {}, r"no pencil line found: 0 pixels darker"),
    (np.full((40, 40), 250, np.uint8), {"levels": 1}, r"levels: expected 2 to 256"),
    (np.full((40, 40), 250, np.uint8), {"px_per_mm": 0.0}, r"px_per_mm: expected a positive"),
])
def test_bad_images_are_refused(grey, kwargs, message):
    with pytest.raises(InputError, match=message):
        extract_profile(grey, **kwargs)


def test_read_scan_accepts_grey_and_grey_rgb_and_16_bit(tmp_path, scan_hb):
    Image.fromarray(scan_hb).save(tmp_path / "grey.png")
    Image.fromarray(np.stack([scan_hb] * 3, axis=-1)).save(tmp_path / "rgb.png")
    Image.fromarray(scan_hb.astype(np.uint16) * 257).save(tmp_path / "deep.png")
    for name in ("grey.png", "rgb.png", "deep.png"):
        assert np.array_equal(read_scan(tmp_path / name), scan_hb), name


def test_read_scan_refuses_each_bad_file_naming_it(tmp_path):
    colour = np.zeros((8, 8, 3), np.uint8)
    colour[..., 0] = 255
    Image.fromarray(colour).save(tmp_path / "colour.png")
    Image.fromarray(np.zeros((8, 8), np.uint8)).convert("P").save(tmp_path / "palette.png")
    Image.fromarray(np.zeros((8, 8), np.uint8)).convert("1").save(tmp_path / "bw.png")
    Image.fromarray(np.zeros((8, 8), np.float32)).save(tmp_path / "float.tiff")
    (tmp_path / "junk.png").write_text("not an image")
    cases = {
        "missing.png": "no such scan file",
        "junk.png": "cannot read the scan as an image",
        "colour.png": r"a colour image \(mode RGB\): expected a greyscale scan",
        "palette.png": "a palette image: expected a greyscale scan",
        "bw.png": r"a black-and-white \(1-bit\) image",
        "float.tiff": "a floating-point image",
    }
    for name, message in cases.items():
        with pytest.raises(InputError, match=message) as caught:
            read_scan(tmp_path / name)
        assert caught.value.file == str(tmp_path / name)


def _png_header(path, width: int, height: int) -> None:
    """A PNG whose header says width x height (8-bit grey) and whose pixels are missing: what
    a decompression bomb looks like before it is decoded."""
    import struct
    import zlib

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(
            ">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    idat = zlib.compress(b"\0" * 64)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", idat)
                     + chunk(b"IEND", b""))


def test_a_huge_image_is_refused_from_its_header_before_decoding(tmp_path):
    for width, height in ((30000, 30000), (9000, 9000)):  # past Pillow's guard, and below it
        scan = tmp_path / f"huge{width}.png"
        _png_header(scan, width, height)
        with pytest.raises(InputError, match=rf"huge{width}.png: .*more than the 50,000,000 "
                                             r"pixels a scan of a line may have"):
            read_scan(scan)


def test_the_command_refuses_it_in_one_line(tmp_path, capsys):
    from inkarm.cli import main

    scan = tmp_path / "huge.png"
    _png_header(scan, 30000, 30000)
    assert main(["pencil", "extract", str(scan), "--out", str(tmp_path / "p.npz")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "900000000 pixels" in err[0] and "50,000,000" in err[0]


def test_a_grey_scan_with_alpha_is_read_as_its_grey(tmp_path):
    grey = np.full((20, 30), 200, dtype=np.uint8)
    grey[9:11] = 40
    Image.fromarray(grey).convert("LA").save(tmp_path / "la.png")
    assert np.array_equal(read_scan(tmp_path / "la.png"), grey)
