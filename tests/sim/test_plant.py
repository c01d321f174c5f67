"""MujocoPlant: the Plant protocol, time keeping, the pen force against the spring law, the ink
contract with the canvas, divergence detection."""

import mujoco
import numpy as np
import pytest

from inkarm.control.ik import solve_ik
from inkarm.control.kinematics import ArmKinematics
from inkarm.control.pid import JointPID
from inkarm.core.plant import Plant, PositionCommand, TorqueCommand
from inkarm.errors import InputError, SimulationError
from inkarm.robots.registry import load_robot
from inkarm.sim.cell import CellConfig, build_model, build_spec, make_cell, page_placement
from inkarm.sim.plant import MujocoPlant, SimState

pytestmark = pytest.mark.sim

IIWA = load_robot("iiwa14")
HOME_Q = IIWA.home_q
JOINT_NAMES = IIWA.joint_names


@pytest.fixture(scope="module")
def model():
    """The default cell; plants share it (they only switch its auto-reset off)."""
    return build_model()


@pytest.fixture(scope="module")
def kin():
    """The controller's own model of the default cell."""
    return ArmKinematics(build_model(), "pen_tip", JOINT_NAMES)


class FakeCanvas:
    """Records the plant's calls."""

    def __init__(self):
        self.calls = []

    def touch(self, p_mm, force_n, t):
        assert np.shape(p_mm) == (2,)
        self.calls.append(("touch", np.array(p_mm, float), float(force_n), float(t)))

    def lift(self):
        self.calls.append(("lift",))


def hold(plant, kin, q_goal, steps):
    """PID with gravity compensation towards q_goal for ``steps`` periods."""
    pid = JointPID(IIWA.gains, plant.dt)
    for _ in range(steps):
        s = plant.read()
        plant.command(TorqueCommand(pid.update(q_goal, s.q, s.qd, feedforward=kin.bias(s.q, s.qd))))
        plant.step()
    return plant.read()


def test_implements_the_plant_protocol_and_keeps_time(model):
    plant = MujocoPlant(model, substeps=3)
    assert isinstance(plant, Plant)
    assert plant.dt == pytest.approx(3 * 0.002)
    state = plant.read()
    assert isinstance(state, SimState)
    assert state.q.shape == (7,) and state.qd.shape == (7,)
    np.testing.assert_allclose(state.q, HOME_Q)
    for _ in range(5):
        plant.step()
    assert plant.read().time == pytest.approx(5 * plant.dt)


def test_without_torque_the_arm_sags_and_with_gravity_compensation_it_stays(model, kin):
    plant = MujocoPlant(model)
    for _ in range(50):
        plant.step()
    assert np.max(np.abs(plant.read().q - HOME_Q)) > 0.01
    plant = MujocoPlant(model)
    for _ in range(50):
        s = plant.read()
        plant.command(TorqueCommand(kin.bias(s.q, s.qd)))
        plant.step()
    assert np.max(np.abs(plant.read().q - HOME_Q)) < 1e-4


def test_read_returns_copies_and_the_tip_in_page_millimetres(model):
    plant = MujocoPlant(model)
    state = plant.read()
    state.q[:] = 0.0
    assert np.allclose(plant.read().q, HOME_Q)
    data = mujoco.MjData(plant.model)
    data.qpos[:7] = HOME_Q
    mujoco.mj_kinematics(plant.model, data)
    page = page_placement(plant.model)
    np.testing.assert_allclose(
        plant.read().tip_mm, page.to_page(data.site("pen_tip").xpos), atol=1e-9
    )


def test_pressed_force_follows_the_spring_and_inks_the_canvas():
    cfg = CellConfig()
    kin = ArmKinematics(build_model(make_cell(cfg)), "pen_tip", JOINT_NAMES)
    page = page_placement(kin.model)
    above = solve_ik(kin, page.to_robot([80.0, 120.0, 2.0]), page.pen_axis, HOME_Q, HOME_Q).q
    pressed = solve_ik(kin, page.to_robot([80.0, 120.0, -2.5]), page.pen_axis, above, above).q
    canvas = FakeCanvas()
    plant = MujocoPlant(build_model(make_cell(cfg)), canvas=canvas, q0=above)
    hold(plant, kin, above, 20)
    assert canvas.calls == [] and plant.read().force == 0.0
    for a in np.linspace(0.0, 1.0, 60):
        hold(plant, kin, above + a * (pressed - above), 1)
    state = hold(plant, kin, pressed, 150)
    # Quasi-static balance of the pen cartridge: contact = preload + spring + its weight along
    # the axis.
    pen_mass = plant.model.body("pen").subtreemass[0]
    expected = cfg.pen_preload_n + cfg.pen_stiffness_n_per_mm * state.pen_compression_mm + \
        pen_mass * 9.81 * (
        page.pen_axis @ [0, 0, -1]
    )
    assert state.force == pytest.approx(expected, rel=0.02)
    assert 0.8 < state.force < 1.5
    touches = [c for c in canvas.calls if c[0] == "touch"]
    assert len(touches) > 100
    np.testing.assert_allclose(touches[-1][1], [80.0, 120.0], atol=0.15)
    assert touches[-1][2] == pytest.approx(state.force, rel=1e-3)
    times = [c[3] for c in touches]
    assert np.all(np.diff(times) > 0) and times[-1] < state.time
    hold(plant, kin, above, 100)
    assert canvas.calls[-1] == ("lift",)
    assert sum(c[0] == "lift" for c in canvas.calls) == 1


def test_close_zeroes_torque_and_lifts_an_inking_pen(model):
    plant = MujocoPlant(model, canvas=FakeCanvas())
    plant.command(TorqueCommand(np.ones(7)))
    plant._touching = True  # as if the pen were on the paper
    plant.close()
    plant.close()
    assert np.all(plant.data.ctrl == 0.0)
    assert plant.canvas.calls == [("lift",)]


def test_position_commands_are_held_by_the_drives(model):
    plant = MujocoPlant(model)
    goal = plant.read().q + 0.05
    for _ in range(150):  # 0.9 s
        plant.command(PositionCommand(goal))
        plant.step()
    np.testing.assert_allclose(plant.read().q, goal, atol=2e-3)


def test_a_plant_without_drives_refuses_position_commands(model):
    class Firmware:  # stands in for servo firmware that was not given
        pass

    plant = MujocoPlant(model)
    plant.drive = None
    with pytest.raises(InputError, match="does not take position commands; it takes: torque"):
        plant.command(PositionCommand(np.zeros(7)))


def test_runaway_speed_is_reported_as_divergence(model):
    plant = MujocoPlant(model, max_joint_speed=20.0)
    plant.data.qvel[3] = 500.0
    with pytest.raises(SimulationError, match=r"joint[0-9] moves at [0-9.]+ rad/s, above the 20.0"):
        plant.step()


def test_non_finite_state_is_reported_as_divergence(model, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # MuJoCo appends its warnings to ./MUJOCO_LOG.TXT
    plant = MujocoPlant(model)
    plant.data.qvel[0] = np.nan
    with pytest.raises(
        SimulationError,
        match=r"diverged at t = [0-9.]+ s: non-finite or huge joint state \(MuJoCo warned "
        r".*mjWARN_BADQVEL",
    ):
        plant.step()


def test_bad_arguments_are_refused(model):
    with pytest.raises(InputError, match="substeps must be >= 1, got 0"):
        MujocoPlant(model, substeps=0)
    with pytest.raises(InputError, match=r"q0: expected 7 angles, got shape \(3,\)"):
        MujocoPlant(model, q0=[0.0, 0.0, 0.0])
    spec = build_spec()
    spec.delete(spec.site("paper_origin"))
    with pytest.raises(
        InputError,
        match="the model needs joint pen_slide, site and geom pen_tip and site paper_origin",
    ):
        MujocoPlant(spec.compile())


def test_the_tip_force_skips_the_contact_list_only_when_nothing_else_can_touch():
    from inkarm.sim.lookups import only_geom_touches

    plain = build_model()
    tip = mujoco.mj_name2id(plain, mujoco.mjtObj.mjOBJ_GEOM, "pen_tip")
    assert only_geom_touches(plain, tip)
    spec = build_spec()
    for name in ("table", "link7"):  # they could now collide (they never do here)
        spec.geom(name).contype, spec.geom(name).conaffinity = 1, 1
    crowded = spec.compile()
    assert not only_geom_touches(crowded, tip)
    spec = build_spec()
    spec.add_pair(geomname1="table", geomname2="link7")
    assert not only_geom_touches(spec.compile(), tip)
    # Both ways of summing the tip's normal force read the same pressed pen.
    kin = ArmKinematics(plain, "pen_tip", JOINT_NAMES)
    page = page_placement(kin.model)
    pressed = solve_ik(kin, page.to_robot([80.0, 120.0, -2.5]), page.pen_axis, HOME_Q,
                       HOME_Q).q
    forces = []
    for m in (plain, crowded):
        plant = MujocoPlant(m, q0=pressed)
        assert plant._only_tip_touches is (m is plain)
        forces.append(hold(plant, kin, pressed, 100).force)
    assert forces[0] > 0.5 and forces[0] == forces[1]
