"""Calibration: measured from the marks through the bus, stored in the user's configuration
folder (an older file beside the profile still read), used by the plant (offsets, reversed
servos, the encoder's wrap)."""

from __future__ import annotations

import shutil
import subprocess
import sys

import numpy as np
import pytest

from inkarm.errors import InputError
from inkarm.hardware.dynamixel.calibration import (
    Calibration,
    calibrate_arm,
    calibration_path,
    find_calibration,
    legacy_calibration_path,
    load_calibration,
    measure,
    save_calibration,
)
from inkarm.hardware.dynamixel.plant import DynamixelPlant
from inkarm.robots.profile import load_profile

pytestmark = pytest.mark.hardware_emulated

OFFSETS = [100.0, 2048.0, 4000.0, 1500.0, 3000.0, 2048.0]   # zero marks near the wrap too
SIGNS = [1, -1, 1, -1, 1, 1]


def _copy_profile(tmp_path):
    from inkarm.robots.registry import DATA

    target = tmp_path / "my_arm.toml"
    shutil.copy(DATA / "wx250s.toml", target)
    return load_profile(target)


def test_calibrate_measures_offsets_and_directions_and_the_plant_uses_them(tmp_path,
                                                                          arm_emulator,
                                                                          monkeypatch):
    monkeypatch.setenv("INKARM_CONFIG_DIR", str(tmp_path / "config"))
    profile = _copy_profile(tmp_path)
    with arm_emulator(profile, offsets=OFFSETS, signs=SIGNS) as emu:
        joints = emu.physics
        script = []
        for j in range(profile.n):  # the user's hands: zero mark, then +90 deg
            script += [(j, 0.0), (j, np.pi / 2)]
        answers = iter(script)

        def ask(prompt):
            j, angle = next(answers)
            with emu.lock:
                joints.q[:] = 0.0
                joints.q[j] = angle
                emu.bank.step()
                emu.bank.sync_registers()
            return ""

        path = calibrate_arm(emu.port, profile, ask=ask, say=lambda text: None)
        assert path == calibration_path(profile) == find_calibration(profile) == \
            tmp_path / "config" / "calibration" / f"{profile.name}.joints.toml"
        assert not legacy_calibration_path(profile).exists()  # nothing beside the profile
        cal = load_calibration(path, profile.joint_names)
        np.testing.assert_allclose(cal.offset_ticks, np.mod(OFFSETS, 4096), atol=1)
        np.testing.assert_array_equal(cal.direction, SIGNS)
        with emu.lock:
            joints.q[:] = profile.home_q
            joints.qd[:] = 0.0
            emu.bank.step()
            emu.bank.sync_registers()
        plant = DynamixelPlant(emu.port, profile, cal)
        np.testing.assert_allclose(plant.read().q, profile.home_q, atol=3e-3)
        plant.close()


def test_a_file_beside_the_profile_is_read_until_there_is_a_new_one(tmp_path, monkeypatch):
    monkeypatch.setenv("INKARM_CONFIG_DIR", str(tmp_path / "config"))
    profile = _copy_profile(tmp_path)
    assert find_calibration(profile) == calibration_path(profile)  # none yet: where it goes
    old = save_calibration(Calibration.identity(profile.joint_names),
                           legacy_calibration_path(profile), profile.name)
    assert old == tmp_path / "my_arm.calibration.toml" == find_calibration(profile)
    new = save_calibration(Calibration.identity(profile.joint_names), calibration_path(profile),
                           profile.name)
    assert find_calibration(profile) == new != old


def test_a_mark_that_is_not_90_degrees_is_refused():
    readings = iter([2048, 2048 + 600])
    with pytest.raises(InputError, match=r"waist: the \+90 deg mark reads \+600 ticks"):
        measure(lambda j: next(readings), ["waist"], ask=lambda _: "", say=lambda _: None)


def test_wrap_around_the_encoder_and_whole_turns():
    readings = iter([4000, 4000 + 1024 - 4096])   # the +90 mark past the wrap reads 928
    cal = measure(lambda j: next(readings), ["waist"], ask=lambda _: "", say=lambda _: None)
    assert cal.offset_ticks[0] == 4000 and cal.direction[0] == 1
    turns = cal.turns([4000 + 4096], [(-np.pi, np.pi)])        # booted a turn away
    assert cal.to_rad([4000 + 4096], turns)[0] == pytest.approx(0.0)
    assert cal.to_ticks([0.5], turns)[0] == pytest.approx(4000 + 4096 + 0.5 * 4096 / (2 * np.pi))


def test_calibration_file_errors_name_the_key(tmp_path):
    path = tmp_path / "a.calibration.toml"
    path.write_text('robot = "x"\n[joints.waist]\noffset_ticks = 10\ndirection = 0\n')
    with pytest.raises(InputError, match=r"joints.waist.direction: expected 1 or -1"):
        load_calibration(path, ["waist"])
    path.write_text("[joints.waist]\noffset_ticks = 1\ndirection = 1\n")
    with pytest.raises(InputError, match=r"joints.elbow: missing"):
        load_calibration(path, ["waist", "elbow"])
    assert Calibration.identity(["a"]).to_rad([2048], [0])[0] == 0.0


def test_inkarm_calibrate_refuses_a_port_it_cannot_open(tmp_path):
    profile = _copy_profile(tmp_path)
    result = subprocess.run(
        [sys.executable, "-m", "inkarm.cli", "calibrate", "--port", "/dev/null-no-such-port",
         "--robot", str(profile.source)], capture_output=True, text=True, timeout=60,
        check=False)
    assert result.returncode == 2
    assert "cannot open /dev/null-no-such-port" in result.stderr
