"""The plant's truth apart from the controller's belief: parsing, draws, and what each field
does to the plant (each checked against what the physics must give)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from inkarm.errors import InputError, ScenarioError
from inkarm.jobs.scenario import load_scenario
from inkarm.sim.cell import PAPER_ORIGIN, kinematic_model, make_cell, page_placement
from inkarm.sim.imperfections import PlantTruth
from inkarm.sim.perturb import plant_model
from inkarm.sim.plant import MujocoPlant
from inkarm.sim.senses import Senses
from inkarm.sim.transmission import Transmission


def test_a_nominal_truth_is_the_model():
    assert PlantTruth().is_nominal and PlantTruth(seed=5).is_nominal
    assert not PlantTruth(paper_height_mm=1.0).is_nominal


def test_random_fields_are_drawn_within_their_ranges_from_the_seed():
    truth = PlantTruth(random={"mass_scale": (0.8, 1.2), "paper_height_mm": (-5.0, 5.0)})
    draws = [truth.realised(seed) for seed in range(50)]
    masses = np.array([d.mass_scale for d in draws])
    assert masses.min() >= 0.8 and masses.max() <= 1.2 and masses.std() > 0.05
    assert all(d.random == {} for d in draws)
    assert truth.realised(7) == truth.realised(7)  # one seed, one plant
    assert truth.realised(7) != truth.realised(8)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"velocity": "guessed"}, (r"velocity: expected one of exact, differences, servo, got "
                              r"'guessed'")),
    ({"mass_scale": 0.0}, r"mass_scale: expected a number in \[0.1, 10\]"),
    ({"sensing_delay_ms": -1.0}, r"sensing_delay_ms: expected a number in \[0, 1000\] ms"),
    ({"coulomb_nm": (1.0, float("nan"))}, r"coulomb_nm: expected finite numbers"),
    ({"random": {"mass_scal": (0.9, 1.1)}}, (r"'mass_scal' cannot be drawn at random \(did you "
                                            r"mean 'mass_scale'\?\)")),
    ({"random": {"mass_scale": (1.2, 0.8)}}, r"random.mass_scale: expected finite low <= high"),
    ({"random": {"mass_scale": (0.0, 2.0)}}, r"random.mass_scale: expected a range within"),
    ({"seed": 1.5}, r"seed: expected a whole number >= 0"),
])
def test_bad_truths_are_refused_naming_the_field(kwargs, message):
    with pytest.raises(InputError, match=message):
        PlantTruth(**kwargs)


def test_per_joint_fields_take_one_number_or_one_per_joint():
    assert PlantTruth(coulomb_nm=2.0).per_joint("coulomb_nm", 3).tolist() == [2.0, 2.0, 2.0]
    with pytest.raises(InputError, match=r"coulomb_nm: expected 1 or 7 numbers \(one per "
                                         r"joint\), got 2"):
        PlantTruth(coulomb_nm=(1.0, 2.0)).per_joint("coulomb_nm", 7)


def test_the_scenario_plant_table_parses_and_round_trips():
    base = load_scenario()
    s = base.with_overrides({"plant.coulomb_nm": [5, 5, 3, 3, 2, 1, 1], "plant.seed": 4,
                             "plant.random.mass_scale": [0.9, 1.1]})
    assert s.plant.coulomb_nm == (5.0, 5.0, 3.0, 3.0, 2.0, 1.0, 1.0) and s.plant.seed == 4
    again = base.with_overrides({"sim.plant": s.to_dict()["sim"]["plant"]})
    assert again.plant == s.plant
    # (the 0.2 spelling plant.* of an override is the [sim.plant] key it names now)
    with pytest.raises(ScenarioError, match=r"sim.plant.mass_scal: unknown key \(did you mean "
                                            r"'mass_scale'\?\)"):
        base.with_overrides({"plant.mass_scal": 1.0})


@pytest.mark.sim
def test_model_level_truth_changes_only_the_plant():
    cell = make_cell()
    nominal = kinematic_model(cell).model
    truth = PlantTruth(mass_scale=1.2, paper_height_mm=-4.0, payload_kg=0.5,
                       coulomb_nm=(5, 5, 3, 3, 2, 1, 1), paper_tilt_deg=2.0)
    model = plant_model(cell, truth)
    arm = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"link{i}") for i in range(1, 8)]
    moving = nominal.body_mass[arm].sum()
    # every link 20 % heavier, plus the payload on the last one
    assert model.body_mass[arm].sum() == pytest.approx(1.2 * moving + 0.5)
    np.testing.assert_allclose(model.dof_frictionloss[:7], [5, 5, 3, 3, 2, 1, 1])
    page = page_placement(model)
    believed = page_placement(nominal)
    origin = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, PAPER_ORIGIN)
    assert origin >= 0
    # the sheet's normal is tilted by 2 degrees; its centre is 4 mm lower
    tilt = np.degrees(np.arccos(page.rotation[:, 2] @ believed.rotation[:, 2]))
    assert tilt == pytest.approx(2.0, abs=1e-6)
    centre = page.to_robot([105.0, 148.5, 0.0])
    assert (centre - believed.to_robot([105.0, 148.5, 0.0]))[2] == pytest.approx(-0.004, abs=1e-6)
    # the controller's model is untouched
    assert kinematic_model(cell).model.body_mass[arm].sum() == pytest.approx(moving)


def test_a_point_payload_moves_the_centre_of_mass_by_the_lever_rule():
    cell = make_cell()
    base, loaded = plant_model(cell), plant_model(cell, PlantTruth(payload_kg=1.2))
    body = mujoco.mj_name2id(base, mujoco.mjtObj.mjOBJ_BODY, "link7")
    site = mujoco.mj_name2id(base, mujoco.mjtObj.mjOBJ_SITE, "flange")
    m0, c0, p = base.body_mass[body], base.body_ipos[body], base.site_pos[site]
    np.testing.assert_allclose(loaded.body_ipos[body], (m0 * c0 + 1.2 * p) / (m0 + 1.2))


def test_encoders_quantise_and_velocity_comes_from_differences():
    senses = Senses(PlantTruth(encoder_ticks_per_rev=4096, velocity="differences"), 2, 0.002)
    tick = 2 * np.pi / 4096
    q = senses.position(np.array([0.3 * tick, 10.6 * tick]))
    np.testing.assert_allclose(q, [0.0, 11 * tick])
    assert senses.velocity(q, np.zeros(2)).tolist() == [0.0, 0.0]
    v = senses.velocity(q + tick, np.zeros(2))
    np.testing.assert_allclose(v, tick / 0.002)


def test_a_backlash_passes_no_torque_inside_the_gap():
    gap = np.radians(0.2)
    trans = Transmission(np.array([0.0]), np.array([gap]), np.array([0.01]), 0.002)
    trans.reset(np.zeros(1), np.zeros(1))
    trans.theta[:] = 0.4 * gap  # inside half the play
    assert trans.coupling(np.zeros(1), np.zeros(1))[0] == 0.0
    trans.theta[:] = 0.5 * gap + 1e-3
    assert trans.coupling(np.zeros(1), np.zeros(1))[0] == pytest.approx(trans.k[0] * 1e-3)


@pytest.mark.sim
def test_an_actuation_delay_holds_back_a_command_by_whole_steps():
    from inkarm.core.plant import TorqueCommand

    truth = PlantTruth(actuation_delay_ms=4.0)
    plant = MujocoPlant(plant_model(make_cell(), truth), truth=truth, substeps=1)
    tau = np.full(7, 1.0)
    plant.command(TorqueCommand(tau))
    plant.step()
    plant.step()
    assert np.all(plant.read().torque == 0.0)  # 2 steps = 4 ms: not yet
    plant.step()
    np.testing.assert_array_equal(plant.read().torque, tau)


@pytest.mark.sim
def test_a_sensing_delay_returns_readings_that_old():
    truth = PlantTruth(sensing_delay_ms=6.0)
    plant = MujocoPlant(plant_model(make_cell(), truth), truth=truth, substeps=1)
    for _ in range(10):
        plant.step()
    assert plant.read().time == pytest.approx(plant.data.time - 0.006)


def test_servo_velocity_comes_in_whole_units_and_the_force_sensor_has_its_bias():
    senses = Senses(PlantTruth(velocity="servo", force_bias_n=0.2), 1, 0.002)
    unit = 0.229 * 2 * np.pi / 60
    np.testing.assert_allclose(senses.velocity(np.zeros(1), np.array([3.4 * unit])), 3 * unit)
    assert senses.force(1.0) == pytest.approx(1.2)
    noisy = Senses(PlantTruth(force_noise_n=0.05, seed=3), 1, 0.002)
    readings = np.array([noisy.force(1.0) for _ in range(4000)])
    assert readings.mean() == pytest.approx(1.0, abs=0.005)
    assert readings.std() == pytest.approx(0.05, rel=0.05)


def _model_bytes(model: mujoco.MjModel) -> dict[str, bytes]:
    return {name: getattr(model, name).tobytes() for name in dir(model)
            if not name.startswith("_") and isinstance(getattr(model, name, None), np.ndarray)}


def test_a_plant_model_is_built_from_a_copy_of_its_cells_spec_with_the_same_bits():
    """plant_model copies the spec it built once per cell (an ensemble's member models): the
    models equal those built from scratch, bit for bit, and one call's edits never reach the
    next."""
    from inkarm.sim.cell import build_spec
    from inkarm.sim.perturb import _change_geometry, _change_links, _move_paper

    cell = make_cell()
    truth = PlantTruth(paper_height_mm=1.5, mass_scale=1.1, com_offset_mm=10.0, payload_kg=0.2,
                       link_length_error_mm=0.5, seed=3)
    spec = build_spec(cell)
    _move_paper(spec, truth)
    scratch = spec.compile()
    _change_links(scratch, cell, truth)
    _change_geometry(scratch, cell, truth)
    extra = lambda s: s.worldbody.add_site(name="edited_once")
    edited = plant_model(cell, truth, edit_spec=extra)
    assert mujoco.mj_name2id(edited, mujoco.mjtObj.mjOBJ_SITE, "edited_once") >= 0
    for _ in range(2):
        again = plant_model(cell, truth)
        assert mujoco.mj_name2id(again, mujoco.mjtObj.mjOBJ_SITE, "edited_once") == -1
        assert _model_bytes(again) == _model_bytes(scratch)


def test_set_const_on_the_threads_scratch_data_gives_a_new_datas_bits(monkeypatch):
    """plant_model's mj_setConst reuses the thread's MjData while the layout stays: after
    other truths, and a model of another layout between them, every model equals the one
    mj_setConst makes on a new MjData, bit for bit."""
    from inkarm.sim import perturb

    cell = make_cell()
    truths = [PlantTruth(mass_scale=1.0 + 0.05 * k, payload_kg=0.1 * k, com_offset_mm=5.0,
                         paper_height_mm=float(k), seed=k) for k in range(4)]
    extra = lambda s: s.worldbody.add_site(name="another_layout")

    def build() -> list[mujoco.MjModel]:
        return [plant_model(cell, t, edit_spec=extra if k == 2 else None)
                for k, t in enumerate(truths)]

    reused = build()
    scratch = perturb._SCRATCH.data
    plant_model(cell, truths[0])
    assert perturb._SCRATCH.data is scratch  # (the same layout: the same data)
    monkeypatch.setattr(perturb, "_set_const",
                        lambda model: mujoco.mj_setConst(model, mujoco.MjData(model)))
    for a, b in zip(reused, build(), strict=True):
        assert _model_bytes(a) == _model_bytes(b)
