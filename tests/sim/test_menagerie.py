"""Menagerie arms (the profiles "menagerie-iiwa14" / "menagerie-panda") loaded from a fake
Menagerie tree.

There is no MuJoCo Menagerie copy in the test environment, so each test writes a small one
under tmp_path: MJCF files at Menagerie's paths with Menagerie's body, joint, site and actuator
names, joint placements and ranges, and its conventions (a position-servo ``general`` actuator
per joint, a ``home`` keyframe with controls, a light, meshes under ``assets/`` named by
``meshdir``, collision geoms in a default class), but primitive collision geoms, one tiny
tetrahedron mesh and round masses instead of the real meshes and inertias.
"""

import dataclasses

import mujoco
import numpy as np
import pytest

from inkarm.control.ik import solve_ik
from inkarm.control.kinematics import ArmKinematics
from inkarm.core.plant import TorqueCommand
from inkarm.errors import InputError, ScenarioError
from inkarm.jobs.run import run
from inkarm.jobs.scenario import parse_scenario
from inkarm.robots.arms.menagerie import model_path
from inkarm.robots.registry import load_robot
from inkarm.sim.cell import CellConfig, build_model, build_spec, make_cell, page_placement
from inkarm.sim.plant import MujocoPlant

pytestmark = pytest.mark.sim

PROFILES = {"iiwa14": load_robot("menagerie-iiwa14"), "panda": load_robot("menagerie-panda")}
MENAGERIE_MODELS = {arm: p.model.menagerie for arm, p in PROFILES.items()}
HOME_Q = load_robot("iiwa14").home_q
JOINT_NAMES = tuple(f"joint{i}" for i in range(1, 8))
ACTUATOR_NAMES = tuple(f"motor{i}" for i in range(1, 8))


def cell_of(arm: str, config: CellConfig | None = None):
    """The drawing cell with the Menagerie ``arm`` ("iiwa14" or "panda")."""
    return make_cell(config, PROFILES[arm])


# (body, pos, quat, joint range) from the base outwards: Menagerie's joint placements in [m].
IIWA14_CHAIN = [
    ("link1", "0 0 0.1575", "1 0 0 0", "-2.96706 2.96706"),
    ("link2", "0 0 0.2025", "0 0 1 1", "-2.0944 2.0944"),
    ("link3", "0 0.2045 0", "0 0 1 1", "-2.96706 2.96706"),
    ("link4", "0 0 0.2155", "1 1 0 0", "-2.0944 2.0944"),
    ("link5", "0 0.1845 0", "0 0 1 1", "-2.96706 2.96706"),
    ("link6", "0 0 0.2155", "1 1 0 0", "-2.0944 2.0944"),
    ("link7", "0 0.081 0", "0 0 1 1", "-3.05433 3.05433"),
]
PANDA_CHAIN = [
    ("link1", "0 0 0.333", "1 0 0 0", "-2.8973 2.8973"),
    ("link2", "0 0 0", "1 -1 0 0", "-1.7628 1.7628"),
    ("link3", "0 -0.316 0", "1 1 0 0", "-2.8973 2.8973"),
    ("link4", "0.0825 0 0", "1 1 0 0", "-3.0718 -0.0698"),
    ("link5", "-0.0825 0.384 0", "1 -1 0 0", "-2.8973 2.8973"),
    ("link6", "0 0 0", "1 1 0 0", "-0.0175 3.7525"),
    ("link7", "0.088 0 0", "1 1 0 0", "-2.8973 2.8973"),
]
FAKES = {
    "iiwa14": ("base", IIWA14_CHAIN, 'pos="0 0 0.045"', "", (3.0, 3.0, 2.5, 2.5, 1.5, 1.2, 0.3)),
    "panda": (
        "link0",
        PANDA_CHAIN,
        'pos="0 0 0.107" quat="0.3826834 0 0 0.9238795"',
        'armature="0.1" damping="1"',
        (2.5, 1.5, 2.0, 2.0, 1.2, 1.0, 0.4),
    ),
}
PANDA_LIMITS = [87, 87, 87, 87, 12, 12, 12]
IIWA_LIMITS = [320, 320, 176, 176, 110, 40, 40]
TETRAHEDRON_OBJ = (
    "v 0 0 0\nv 0.04 0 0\nv 0 0.04 0\nv 0 0 0.04\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
)


def fake_mjcf(arm: str) -> str:
    """MJCF text of the fake ``arm`` ("iiwa14" or "panda")."""
    base, chain, site, joint_defaults, masses = FAKES[arm]
    head = f"""<mujoco model="fake {arm}">
  <compiler angle="radian" meshdir="assets" autolimits="true"/>
  <option integrator="implicitfast" impratio="10"/>
  <default>
    <default class="arm">
      <joint axis="0 0 1" {joint_defaults}/>
      <general biastype="affine" gainprm="2000" biasprm="0 -2000 -200"/>
      <default class="visual"><geom type="mesh" contype="0" conaffinity="0" group="2"/></default>
      <default class="collision"><geom type="sphere" size="0.06" group="3"/></default>
    </default>
  </default>
  <asset><mesh name="shell" file="shell.obj"/></asset>
  <worldbody>
    <light name="top" pos="0 0 2"/>
    <body name="{base}" childclass="arm">
      <inertial mass="4" pos="0 0 0.05" diaginertia="0.03 0.03 0.02"/>
      <geom class="collision"/>
"""
    body = ""
    for (name, pos, quat, rng), mass in zip(chain, masses):
        joint = name.replace("link", "joint")
        body += f"""<body name="{name}" pos="{pos}" quat="{quat}">
<inertial mass="{mass}" pos="0 0 0.04" diaginertia="{0.02 * mass} {0.02 * mass} {0.005 * mass}"/>
<joint name="{joint}" range="{rng}"/>
<geom class="visual" mesh="shell"/>
<geom class="collision"/>
"""
    body += f'<site name="attachment_site" {site}/>\n' + "</body>\n" * len(chain)
    actuators = "".join(
        f'<general name="actuator{i}" joint="joint{i}" class="arm"/>\n' for i in range(1, 8)
    )
    home = "0 0.5 0 -1.5 0 0.5 0" if arm == "iiwa14" else "0 0 0 -1.57079 0 1.57079 -0.7853"
    tail = f"""    </body>
  </worldbody>
  <contact><exclude body1="{base}" body2="link1"/></contact>
  <actuator>
{actuators}  </actuator>
  <keyframe><key name="home" qpos="{home}" ctrl="{home}"/></keyframe>
</mujoco>
"""
    return head + body + tail


@pytest.fixture
def menagerie(tmp_path, monkeypatch):
    """A fake Menagerie tree with both arms; MENAGERIE_ROOT points at it."""
    for arm, relative in MENAGERIE_MODELS.items():
        path = tmp_path / relative
        (path.parent / "assets").mkdir(parents=True)
        (path.parent / "assets" / "shell.obj").write_text(TETRAHEDRON_OBJ)
        path.write_text(fake_mjcf(arm))
    monkeypatch.setenv("MENAGERIE_ROOT", str(tmp_path))
    return tmp_path


@pytest.fixture(scope="module")
def builtin_model():
    return build_model()


@pytest.fixture(scope="module")
def builtin_home_tip(builtin_model) -> np.ndarray:
    model = builtin_model
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_kinematics(model, data)
    return data.site("pen_tip").xpos.copy()


def dh_flange(q, a, d, alpha):
    """Flange position from a modified (Craig) DH table; the Panda's is published so."""
    T = np.eye(4)
    for qi, ai, di, al in zip(q, a, d, alpha):
        ca, sa, ct, st = np.cos(al), np.sin(al), np.cos(qi), np.sin(qi)
        T = T @ np.array(
            [
                [ct, -st, 0, ai],
                [st * ca, ct * ca, -sa, -sa * di],
                [st * sa, ct * sa, ca, ca * di],
                [0, 0, 0, 1],
            ]
        )
    return (T @ [0.0, 0.0, 0.107, 1.0])[:3]


@pytest.mark.parametrize("arm, limits", [("iiwa14", IIWA_LIMITS), ("panda", PANDA_LIMITS)])
def test_menagerie_arm_has_seven_torque_motors_and_the_cell(menagerie, arm, limits):
    model = build_model(cell_of(arm))
    hinges = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    assert [model.joint(j).name for j in hinges] == list(JOINT_NAMES)
    assert [model.actuator(i).name for i in range(model.nu)] == list(ACTUATOR_NAMES)
    assert list(model.actuator_trnid[:, 0]) == hinges
    # motors: force = ctrl, no bias (Menagerie's position servos are gone)
    np.testing.assert_array_equal(model.actuator_gaintype, mujoco.mjtGain.mjGAIN_FIXED)
    np.testing.assert_array_equal(model.actuator_gainprm[:, 0], 1.0)
    np.testing.assert_array_equal(model.actuator_biastype, mujoco.mjtBias.mjBIAS_NONE)
    np.testing.assert_allclose(model.actuator_ctrlrange[:, 1], limits)
    np.testing.assert_allclose(model.actuator_ctrlrange[:, 0], -np.array(limits))
    assert all(model.actuator_ctrllimited)
    assert all(model.dof_armature[:7] > 0) and all(model.dof_damping[:7] > 0)
    pen = model.joint("pen_slide")
    assert pen.type[0] == mujoco.mjtJoint.mjJNT_SLIDE and model.jnt_stiffness[pen.id] == 300.0
    for kind, name in [
        (mujoco.mjtObj.mjOBJ_SITE, "pen_tip"),
        (mujoco.mjtObj.mjOBJ_SITE, "flange"),
        (mujoco.mjtObj.mjOBJ_SITE, "paper_origin"),
        (mujoco.mjtObj.mjOBJ_GEOM, "pen_tip"),
        (mujoco.mjtObj.mjOBJ_GEOM, "paper"),
        (mujoco.mjtObj.mjOBJ_CAMERA, "paper_top"),
        (mujoco.mjtObj.mjOBJ_CAMERA, "overview"),
        (mujoco.mjtObj.mjOBJ_CAMERA, "pen_cam"),
    ]:
        assert mujoco.mj_name2id(model, kind, name) >= 0, name
    assert model.nkey == 1 and model.key(0).name == "home"
    assert model.nlight == 1 and model.opt.impratio == 1.0
    assert model.nmesh == 1  # the arm's own meshes are kept


@pytest.mark.parametrize("arm", ["iiwa14", "panda"])
def test_only_the_pen_tip_and_the_paper_can_collide(menagerie, arm):
    model = build_model(cell_of(arm))

    def can_collide(a, b):
        return bool(
            model.geom_contype[a] & model.geom_conaffinity[b]
            or model.geom_contype[b] & model.geom_conaffinity[a]
        )

    pairs = {
        tuple(sorted((model.geom(a).name, model.geom(b).name)))
        for a in range(model.ngeom)
        for b in range(a + 1, model.ngeom)
        if can_collide(a, b)
    }
    assert pairs == {("paper", "pen_tip")} and model.npair == 0


def test_iiwa14_has_the_builtin_kinematics_so_it_shares_the_home_pose(menagerie, builtin_model):
    menagerie_model = build_model(cell_of("iiwa14"))
    builtin = builtin_model
    rng = np.random.default_rng(0)
    for q in [np.array(HOME_Q), *rng.uniform(-1.5, 1.5, (20, 7))]:
        poses = []
        for model in (menagerie_model, builtin):
            data = mujoco.MjData(model)
            data.qpos[:7] = q
            mujoco.mj_kinematics(model, data)
            poses.append(
                (
                    data.site("flange").xpos.copy(),
                    data.site("pen_tip").xpos.copy(),
                    data.site("flange").xmat.reshape(3, 3)[:, 2].copy(),
                )
            )
        for a, b in zip(*poses):
            np.testing.assert_allclose(a, b, atol=1e-9)
    np.testing.assert_allclose(menagerie_model.key("home").qpos, [*HOME_Q, 0.0, 0.0])


def test_panda_flange_follows_the_published_dh_table(menagerie):
    model = build_model(cell_of("panda"))
    a = [0.0, 0.0, 0.0, 0.0825, -0.0825, 0.0, 0.088]
    d = [0.333, 0.0, 0.316, 0.0, 0.384, 0.0, 0.0]
    alpha = [0.0, -np.pi / 2, np.pi / 2, np.pi / 2, -np.pi / 2, np.pi / 2, np.pi / 2]
    data = mujoco.MjData(model)
    rng = np.random.default_rng(1)
    for q in rng.uniform(model.jnt_range[:7, 0], model.jnt_range[:7, 1], (20, 7)):
        data.qpos[:7] = q
        mujoco.mj_kinematics(model, data)
        np.testing.assert_allclose(data.site("flange").xpos, dh_flange(q, a, d, alpha), atol=1e-9)
        # the pen lies along the flange axis, 135 mm out
        axis = data.site("flange").xmat.reshape(3, 3)[:, 2]
        offset = data.site("pen_tip").xpos - data.site("flange").xpos
        np.testing.assert_allclose(offset, 0.1355 * axis, atol=1e-9)


@pytest.mark.parametrize("arm", ["iiwa14", "panda"])
def test_home_points_the_pen_down_above_the_paper_and_ik_reaches_the_sheet(
    menagerie, arm, builtin_home_tip
):
    model = build_model(cell_of(arm))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_kinematics(model, data)
    tip = data.site("pen_tip")
    assert tip.xmat.reshape(3, 3)[:, 2] @ [0, 0, -1] > 0.99
    if arm == "iiwa14":  # the builtin's home
        np.testing.assert_allclose(tip.xpos, builtin_home_tip, atol=1e-9)
    else:  # 150 mm above the sheet's centre
        np.testing.assert_allclose(tip.xpos, [0.6, 0.0, 0.15], atol=0.002)

    kin = ArmKinematics(model, "pen_tip", JOINT_NAMES)
    page = page_placement(model)
    home = PROFILES[arm].home_q
    for corner in [(20.0, 20.0), (190.0, 277.0), (105.0, 148.5)]:
        goal = page.to_robot([*corner, 0.0])
        result = solve_ik(kin, goal, page.pen_axis, home, home)
        assert result.converged, (arm, corner, result)
        assert np.all(result.q >= kin.lower) and np.all(result.q <= kin.upper)
        p, R = kin.fk(result.q)
        np.testing.assert_allclose(page.to_page(p), [*corner, 0.0], atol=1e-3)
        assert R[:, 2] @ page.pen_axis > 1 - 1e-9


def test_panda_home_is_its_own_and_a_profile_home_reaches_the_keyframe(menagerie):
    panda = PROFILES["panda"]
    assert not np.allclose(panda.home_q, HOME_Q)
    np.testing.assert_allclose(PROFILES["iiwa14"].home_q, HOME_Q)
    q = (0.1, 0.2, 0.0, -2.0, 0.0, 2.2, 0.7)
    moved = dataclasses.replace(
        panda, joints=tuple(dataclasses.replace(j, home=h) for j, h in zip(panda.joints, q))
    )
    model = build_model(make_cell(robot=moved))
    np.testing.assert_allclose(model.key("home").qpos, [*q, 0.0, 0.0])


@pytest.mark.parametrize("arm, limits", [("iiwa14", IIWA_LIMITS), ("panda", PANDA_LIMITS)])
def test_default_gains_saturate_at_the_arm_torque_limits(arm, limits):
    gains = PROFILES[arm].gains
    np.testing.assert_allclose(gains.torque_limit, limits)
    assert np.all(gains.integral_limit < gains.torque_limit)


def test_panda_plant_holds_its_home_pose_under_pid(menagerie):
    from inkarm.control.pid import JointPID

    cell = cell_of("panda")
    plant = MujocoPlant(build_model(cell), cell=cell)
    kin = ArmKinematics(build_model(cell), "pen_tip", JOINT_NAMES)
    pid = JointPID(cell.robot.gains, plant.dt)
    goal = cell.robot.home_q + 0.05
    for _ in range(300):
        s = plant.read()
        plant.command(TorqueCommand(pid.update(goal, s.q, s.qd, feedforward=kin.bias(s.q, s.qd))))
        plant.step()
    np.testing.assert_allclose(plant.read().q, goal, atol=2e-3)
    plant.close()


def test_a_panda_scenario_draws_with_the_panda_gains(menagerie, tmp_path):
    t = np.linspace(0.0, 1.0, 101)
    rows = "\n".join(f"{ti},{60.0 + 80.0 * ti},{100.0 + 40.0 * ti}" for ti in t)
    (tmp_path / "line.csv").write_text("t,x,y\n" + rows + "\n")
    scenario = parse_scenario(
        {
            "source": {"kind": "trajectory", "file": "line.csv"},
            "robot": {"name": "menagerie-panda"},
            # this stand-in Panda slides 7.6 mm off its path as the pen lands
            "controller": {"tracking_limit_mm": 10.0},
        },
        base_dir=tmp_path,
    )
    result = run(scenario)
    assert result.status in ("ok", "degraded"), result.reason
    metrics = result.metrics
    # With the iiwa's gains this Panda hunts: 1.9 mm RMS and the force swings by 0.3 N (std).
    # (Its gains were tuned on the cell before it had joint friction, a pen preload and an
    # underlay: 1.6 mm now, degraded by the 1 mm bound.)
    assert metrics["tracking_rms_mm"] < 2.0
    assert abs(metrics["contact_force_mean_n"] - 1.0) < 0.1
    assert metrics["contact_force_std_n"] < 0.1


def test_model_paths_lie_under_menagerie_root(menagerie):
    for relative in MENAGERIE_MODELS.values():
        assert model_path(relative) == menagerie / relative
    with pytest.raises(InputError, match=r"no file .*nope\.xml"):
        model_path("nope.xml")


def test_spec_from_menagerie_is_editable_before_compiling(menagerie):
    spec = build_spec(cell_of("iiwa14", CellConfig(timestep=0.001)))
    assert spec.compile().opt.timestep == 0.001


def test_scenario_robot_table_selects_the_arm(menagerie):
    scenario = parse_scenario({"source": {"kind": "tag"}, "robot": {"name": "menagerie-panda"}})
    assert scenario.robot.name == "menagerie-panda"
    assert scenario.robot.model.menagerie == MENAGERIE_MODELS["panda"]
    with pytest.raises(ScenarioError, match=r"robot.name: unknown value 'ur5'.*'iiwa14'"):
        parse_scenario({"source": {"kind": "tag"}, "robot": {"name": "ur5"}})


# -- errors ---------------------------------------------------------------------------------------


def test_unknown_arm_is_refused():
    with pytest.raises(
        InputError,
        match=r"robot: unknown robot 'ur5'.*expected one of 'iiwa14', 'menagerie-iiwa14', "
        r"'menagerie-panda'",
    ):
        load_robot("ur5")


@pytest.mark.parametrize("arm", ["iiwa14", "panda"])
def test_unset_menagerie_root_names_the_variable_and_the_path(monkeypatch, arm):
    monkeypatch.delenv("MENAGERIE_ROOT", raising=False)
    expected = MENAGERIE_MODELS[arm].replace(".", r"\.")
    with pytest.raises(
        InputError,
        match=rf"set the environment variable MENAGERIE_ROOT.*"
        rf"\$MENAGERIE_ROOT/{expected}",
    ):
        build_model(cell_of(arm))


def test_missing_model_file_names_the_path(tmp_path, monkeypatch):
    monkeypatch.setenv("MENAGERIE_ROOT", str(tmp_path))
    path = tmp_path / "franka_emika_panda" / "panda_nohand.xml"
    with pytest.raises(InputError, match=rf"no file {path}.*MENAGERIE_ROOT="):
        build_spec(cell_of("panda"))


def test_missing_mesh_names_the_mesh(menagerie):
    shell = menagerie / "kuka_iiwa_14" / "assets" / "shell.obj"
    shell.unlink()
    with pytest.raises(InputError, match=rf"needs the mesh {shell}, which is missing"):
        build_model(cell_of("iiwa14"))


def test_unreadable_model_file_is_an_input_error(menagerie):
    (menagerie / "kuka_iiwa_14" / "iiwa14.xml").write_text("<mujoco><worldbody>")
    with pytest.raises(InputError, match=r"cannot read .*iiwa14\.xml"):
        build_model(cell_of("iiwa14"))


def test_a_model_without_the_expected_joints_is_refused(menagerie):
    path = menagerie / "kuka_iiwa_14" / "iiwa14.xml"
    path.write_text(path.read_text().replace('name="joint7"', 'name="a7"'))
    with pytest.raises(InputError, match=r"missing \['joint7'\], unexpected \['a7'\]"):
        build_model(cell_of("iiwa14"))


def test_a_model_without_the_flange_site_is_refused(menagerie):
    path = menagerie / "kuka_iiwa_14" / "iiwa14.xml"
    path.write_text(path.read_text().replace("attachment_site", "tool"))
    with pytest.raises(InputError, match=r"no site 'attachment_site' to mount the pen on"):
        build_model(cell_of("iiwa14"))
