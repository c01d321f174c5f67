"""The cell calibration file: the height map's interpolation (oracles: functions bilinear
interpolation reproduces exactly), the TOML round trip bit for bit, every error naming the file,
key and value, and where the file lives."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from inkarm.errors import InputError, ScenarioError
from inkarm.robots.calibration import (
    CellCalibration,
    HeightMap,
    calibration_dir,
    calibration_path,
    read_calibration,
    write_calibration,
)
from inkarm.robots.geometry import GeometryErrors


def _bilinear(x, y):
    """Reproduced exactly by bilinear interpolation on any grid: a + b x + c y + d x y."""
    return 0.3 + 0.02 * x - 0.01 * y + 0.0005 * x * y


def test_height_reproduces_a_bilinear_function_and_holds_the_edges():
    x, y = np.array([0.0, 7.0, 20.0, 21.5]), np.array([-5.0, 3.0, 40.0])
    m = HeightMap(x, y, _bilinear(*np.meshgrid(x, y)))
    rng = np.random.default_rng(1)
    px, py = rng.uniform(0, 21.5, 200), rng.uniform(-5, 40, 200)
    np.testing.assert_allclose(m.height(px, py), _bilinear(px, py), atol=1e-12)
    assert isinstance(m.height(3.0, 4.0), float)
    assert m.height(3.0, 4.0) == pytest.approx(_bilinear(3.0, 4.0), abs=1e-12)
    # outside: the edge's value (clamped), on both axes
    assert m.height(-100.0, 50.0) == pytest.approx(_bilinear(0.0, 40.0), abs=1e-12)
    assert m.height(np.array([30.0]), np.array([-9.0]))[0] == pytest.approx(_bilinear(21.5, -5.0))
    # broadcasting: a row of x against one y
    assert m.height(np.array([1.0, 2.0]), 0.0).shape == (2,)
    assert m.range_mm == (float(m.z_mm.min()), float(m.z_mm.max()))


def test_slope_is_the_bilinear_surfaces_and_zero_where_clamped():
    x, y = np.array([0.0, 10.0, 20.0]), np.array([0.0, 10.0])
    m = HeightMap(x, y, _bilinear(*np.meshgrid(x, y)))
    gx, gy = m.slope(4.0, 6.0)
    assert gx == pytest.approx(0.02 + 0.0005 * 6.0) and gy == pytest.approx(-0.01 + 0.0005 * 4.0)
    gx, gy = m.slope(np.array([25.0, 5.0]), np.array([5.0, -3.0]))
    assert gx[0] == 0.0 and gy[1] == 0.0


def test_a_single_grid_line_is_constant_along_it():
    m = HeightMap([5.0], [0.0, 10.0], [[1.0], [3.0]])
    assert m.height(-50.0, 5.0) == pytest.approx(2.0) == m.height(50.0, 5.0)
    assert m.slope(0.0, 5.0)[0] == 0.0


def test_the_map_is_read_only_and_checked():
    m = HeightMap([0.0, 1.0], [0.0, 1.0], [[0.0, 0.0], [0.0, 1.0]])
    with pytest.raises(ValueError):
        m.z_mm[0, 0] = 5.0
    with pytest.raises(InputError, match=r"x_mm: expected finite, strictly increasing"):
        HeightMap([0.0, 0.0], [0.0, 1.0], np.zeros((2, 2)))
    with pytest.raises(InputError, match=r"y_mm: expected at least one grid line"):
        HeightMap([0.0], [], np.zeros((0, 1)))
    with pytest.raises(InputError, match=r"z_mm: expected shape \(len\(y_mm\), len\(x_mm\)\) = "
                                         r"\(2, 3\), got \(3, 2\)"):
        HeightMap([0.0, 1.0, 2.0], [0.0, 1.0], np.zeros((3, 2)))
    with pytest.raises(InputError, match=r"z_mm: expected finite heights"):
        HeightMap([0.0, 1.0], [0.0, 1.0], [[0.0, np.nan], [0.0, 0.0]])


def _calibration() -> CellCalibration:
    x, y = np.array([10.0, 12.5, 15.0]), np.array([100.0, 101.0])
    z = np.array([[0.1, -1e-7, 1 / 3], [2.0, 0.0, -0.25]])
    return CellCalibration(
        robot="iiwa14", paper=HeightMap(x, y, z),
        geometry=GeometryErrors(link_length_mm=(0.0, 0.3, -0.1, 0, 0, 0, 1e-9),
                                joint_offset_deg=(0.1,) * 7, tip_offset_mm=(0.5, -0.25, 2.0)),
        notes=('paper: "quoted", a \\ backslash\nand a new line', "pen: 2 mm, ü"))


def test_write_then_read_gives_back_every_number_exactly(tmp_path):
    cal = _calibration()
    path = write_calibration(cal, tmp_path / "deep" / "er" / "iiwa14.toml")
    assert path.is_file() and not list(path.parent.glob(".*partial"))
    back = read_calibration(path)
    assert back.robot == "iiwa14" and back.notes == cal.notes and back.geometry == cal.geometry
    for name in ("x_mm", "y_mm", "z_mm"):
        np.testing.assert_array_equal(getattr(back.paper, name), getattr(cal.paper, name))
    empty = read_calibration(write_calibration(CellCalibration("wx250s"), tmp_path / "e.toml"))
    assert empty.paper is None and empty.geometry.is_zero and empty.is_empty
    assert empty.describe() == "nothing (empty)"
    assert "paper map 3x2" in cal.describe() and "pen tip (+0.50, -0.25, +2.00) mm" in \
        cal.describe()


def test_a_non_finite_number_is_not_written(tmp_path):
    bad = CellCalibration("x", paper=None, geometry=GeometryErrors())
    object.__setattr__(bad.geometry, "tip_offset_mm", (0.0, float("inf"), 0.0))
    with pytest.raises(InputError, match="finite numbers only"):
        write_calibration(bad, tmp_path / "x.toml")
    assert not (tmp_path / "x.toml").exists()


@pytest.mark.parametrize("text, match", [
    ('notes = []', r"robot: missing: the robot profile's name"),
    ('robot = 3', r"robot: expected a string, got 3"),
    ('robot = "a"\nrobt = 1', r"robt: unknown key \(did you mean 'robot'\?\)"),
    ('robot = "a"\nnotes = "x"', r"notes: expected an array of strings"),
    ('robot = "a"\nnotes = [1]', r"notes\[0\]: expected a string"),
    ('robot = "a"\n[geometry]\nlink_length_mm = [1.0, 2.0]',
     r"geometry.link_length_mm\[0\]: expected 0 \(joint 0 has no link before it\)"),
    ('robot = "a"\n[geometry]\ntip_offset_mm = [1.0, 2.0]',
     r"geometry.tip_offset_mm: expected 3 numbers \(x, y, z in the flange frame\) \[mm\], got 2"),
    ('robot = "a"\n[geometry]\njoint_offset_deg = ["a"]',
     r"geometry.joint_offset_deg\[0\]: expected a number"),
    ('robot = "a"\n[geometry]\ntip_mm = [0, 0, 0]',
     r"geometry.tip_mm: unknown key \(did you mean 'tip_offset_mm'\?\)"),
    ('robot = "a"\n[paper]\nx_mm = [0.0, 1.0]\ny_mm = [0.0]',
     r"paper.z_mm: missing: a height map needs x_mm, y_mm and z_mm"),
    ('robot = "a"\n[paper]\nx_mm = [0.0, 1.0]\ny_mm = [0.0]\nz_mm = [[1.0, 2.0, 3.0]]',
     r"paper.z_mm: expected shape \(len\(y_mm\), len\(x_mm\)\) = \(1, 2\), got \(1, 3\)"),
    ('robot = "a"\n[paper]\nx_mm = [1.0, 0.0]\ny_mm = [0.0]\nz_mm = [[1.0, 2.0]]',
     r"paper.x_mm: expected finite, strictly increasing grid lines"),
    ('robot = "a"\n[paper]\nx_mm = [0.0, 1.0]\ny_mm = [0.0, 1.0]\nz_mm = [[1.0, 2.0], [1.0]]',
     r"paper.z_mm: rows have different lengths"),
    ('robot = "a"\npaper = 3', r"paper: expected a table"),
    ('robot = "a"\n[geometry]\ntip_offset_mm = [0, 0, 500]',
     r"geometry.tip_offset_mm: expected corrections within \+-50 mm, got 500"),
    ('robot = "a"\n[geometry]\njoint_offset_deg = [0, 45]',
     r"geometry.joint_offset_deg: expected corrections within \+-10 deg, got 45"),
    ('robot = "a"\n[paper]\nx_mm = [0.0, 1.0]\ny_mm = [0.0]\nz_mm = [[1e9, 2.0]]',
     r"paper.z_mm: expected corrections within \+-50 mm, got 1e\+09"),
    ('robot = "a', r"not valid TOML"),
])
def test_every_error_names_the_file_and_key(tmp_path, text, match):
    path = tmp_path / "cal.toml"
    path.write_text(text)
    with pytest.raises(ScenarioError, match=match) as info:
        read_calibration(path)
    assert str(path) in str(info.value)


def test_a_missing_file_says_so(tmp_path):
    with pytest.raises(ScenarioError, match=r"no such calibration file"):
        read_calibration(tmp_path / "none.toml")


def test_the_configuration_folder_follows_the_environment(monkeypatch, tmp_path):
    monkeypatch.delenv("INKARM_CONFIG_DIR", raising=False)
    monkeypatch.delenv("XDG_CONFIG_HOME", raising=False)
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert calibration_dir() == tmp_path / "home" / ".config" / "inkarm"
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "xdg"))
    assert calibration_dir() == tmp_path / "xdg" / "inkarm"
    monkeypatch.setenv("INKARM_CONFIG_DIR", str(tmp_path / "mine"))
    assert calibration_dir() == tmp_path / "mine"
    assert calibration_path("wx250s") == tmp_path / "mine" / "calibration" / "wx250s.toml"
    for bad in ("", "../x", "a/b", ".."):
        with pytest.raises(InputError, match=r"robot: a robot name makes a file name"):
            calibration_path(bad)


def test_the_package_holds_no_calibration_file():
    package = Path(__file__).parents[2] / "inkarm"
    assert not list(package.rglob("*.calibration.toml"))
    assert not list(package.rglob("*.joints.toml"))
