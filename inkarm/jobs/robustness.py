"""Issue 9's robustness conditions as data: plants that differ from the controller's model, one
imperfection at a time and all at once, plants beyond the controller's reach with the watchdog
that must stop each, and the bounds a drawing must keep. ``tests/sim/test_robustness.py`` and
``benchmarks/bench_robustness.py`` run the same conditions; a user can run them on their own
controller the same way (``run(scenario.with_overrides(overrides(plant)))``).

Each plant is a ``[plant]`` table (:class:`inkarm.sim.imperfections.PlantTruth` fields, SI and
[mm], [ms] as named).
"""

from __future__ import annotations

# Series elasticity per joint of the iiwa [N m/rad]: harmonic drives with torque sensors.
ELASTIC = [2e4, 2e4, 1e4, 1e4, 5e3, 2e3, 2e3]
HARD_PAPER = {"paper_stiffness_n_per_mm": 0.0, "paper_timeconst_s": 0.002, "nib_friction": 0.3}
ONE_AT_A_TIME = {
    "paper +5 mm": {"paper_height_mm": 5.0},
    "paper -5 mm": {"paper_height_mm": -5.0},
    "paper tilted 2 deg": {"paper_tilt_deg": 2.0},
    "masses +20 %, centres of mass 20 mm off": {"mass_scale": 1.2, "com_offset_mm": 20.0},
    "masses -20 %, centres of mass 20 mm off": {"mass_scale": 0.8, "com_offset_mm": 20.0},
    "payload 0.5 kg": {"payload_kg": 0.5},
    "Coulomb friction 5/5/3/3/2/1/1 N m": {"coulomb_nm": [5, 5, 3, 3, 2, 1, 1]},
    "series elasticity 2e4..2e3 N m/rad": {"elasticity_nm_per_rad": ELASTIC},
    "q noise 1e-4 rad, velocity from differences": {"q_noise_rad": 1e-4,
                                                    "velocity": "differences"},
    "2 ms sensing + 2 ms actuation delay": {"sensing_delay_ms": 2.0, "actuation_delay_ms": 2.0},
    "hard paper (rigid, solref 2 ms), nib friction 0.3": HARD_PAPER,
}
ALL_AT_ONCE = {k: v for plant in ONE_AT_A_TIME.values() for k, v in plant.items()}
ALL_BUT_ELASTIC = {k: v for k, v in ALL_AT_ONCE.items() if k != "elasticity_nm_per_rad"}
# An ensemble around the mix: each member's masses, paper and payload drawn from plant.seed.
AROUND_ALL_AT_ONCE = {"mass_scale": [0.8, 1.2], "paper_height_mm": [-5.0, 5.0],
                      "paper_tilt_deg": [0.0, 2.0], "paper_tilt_axis_deg": [0.0, 360.0],
                      "payload_kg": [0.0, 0.5]}
BEYOND_REACH = {  # plant -> the watchdog that must stop it
    "paper 30 mm lower": ({"paper_height_mm": -30.0}, "paper_not_found"),
    "paper 20 mm higher": ({"paper_height_mm": 20.0}, "force_limit"),
    "actuation delay 40 ms": ({"actuation_delay_ms": 40.0}, "tracking_limit"),
    "sensing 30 + actuation 30 ms": ({"sensing_delay_ms": 30.0, "actuation_delay_ms": 30.0},
                                     "tracking_limit"),
    "series elasticity 100 N m/rad": ({"elasticity_nm_per_rad": 100.0}, "force_limit"),
    "encoder 64 ticks/rev": ({"encoder_ticks_per_rev": 64, "velocity": "differences"},
                             "torque_saturated"),
    "torque limits 10 % (below gravity)": ({"torque_limit_scale": 0.1}, "joint_speed"),
}
# tracking RMS [mm], ink chamfer [mm], gaps [mm], half-width of the force band [N] around the
# set point (1st to 99th percentile of the drawing samples)
BOUNDS = {"tracking_rms_mm": 0.3, "ink_chamfer_mm": 0.3, "gap_mm": 0.0, "force_band_n": 0.1}
# A fault must have the pen off the paper within this much simulated time [s].
SAFE_WITHIN_S = 0.1
# The controller for the hardest plants (springs, heavier links, a rigid table with nib friction
# all at once): the paper probed before drawing, so the first stroke knows the sheet, and a
# force loop 2.5 times slower than the default, below the springs' mode (k_F = 100
# mm/(N s) drives that mix into a limit cycle in contact). It meets every row above as well.
CAREFUL_CONTROLLER = {"controller.probe_paper": True, "controller.force_gain_mm_per_ns": 40.0}


# Issue 23: the real sheet and the real arm. Each alone is mild; a hobby arm on a desk has them
# all. The wave runs along page y, across the letter's long strokes (the harder direction).
WAVY_SHEET = {"relief_wave_mm": 1.0, "relief_wavelength_mm": 30.0,
              "relief_wave_direction_deg": 90.0}
# On the N's diagonal (the sheet's centre lies 6.6 mm from every stroke).
BUMP = {"relief_bump_mm": 1.0, "relief_bump_width_mm": 8.0, "relief_bump_x_mm": 110.5,
        "relief_bump_y_mm": 152.7}
PEN_OFF = {"pen_length_error_mm": 2.0, "pen_offset_mm": 1.0}
ARM_OFF = {"link_length_error_mm": 1.0, "joint_offset_error_deg": 0.2}  # seeded per joint
REAL_WORLD = {
    "sheet with a 1 mm wave, 30 mm wavelength": WAVY_SHEET,
    "a 1 mm bump, 8 mm wide, under the letter": BUMP,
    "pen tip 2 mm longer and 1 mm off-axis": PEN_OFF,
    "links off by up to 1 mm, joints by up to 0.2 deg": ARM_OFF,
}
# Coulomb friction 1.5x the README's row, 2 + 2 ms delays, base tilted 1 deg, 0-6 ms read-out
# jitter, on top of every condition above.
REAL_MIX = {**WAVY_SHEET, **BUMP, **PEN_OFF, **ARM_OFF,
            "coulomb_nm": [7.5, 7.5, 4.5, 4.5, 3.0, 1.5, 1.5],
            "sensing_delay_ms": 2.0, "actuation_delay_ms": 2.0,
            "base_tilt_deg": 1.0, "base_tilt_axis_deg": 30.0, "readout_jitter_ms": 6.0}
# An ensemble around the mix: each member's relief, pen, arm and tilt drawn from plant.seed.
AROUND_REAL_MIX = {"relief_wave_mm": [0.5, 1.0], "relief_wave_direction_deg": [0.0, 180.0],
                   "relief_wave_phase_deg": [0.0, 360.0], "relief_bump_mm": [-1.0, 1.0],
                   "pen_length_error_mm": [-2.0, 2.0], "pen_offset_mm": [0.0, 1.0],
                   "pen_offset_direction_deg": [0.0, 360.0], "base_tilt_deg": [0.0, 1.0],
                   "base_tilt_axis_deg": [0.0, 360.0]}


def overrides(plant: dict, knows_latency: bool = True, careful: bool = False,
              seed: int | None = None) -> dict:
    """Scenario overrides for ``plant``; with ``knows_latency`` its actuation delay is the
    controller's ``lookahead_s`` (what a user who measured the latency would set); with
    ``careful`` the controller is :data:`CAREFUL_CONTROLLER`; with ``seed`` the member
    ``plant.seed = seed`` of the ensemble :data:`AROUND_ALL_AT_ONCE` around ``plant``."""
    out = {f"plant.{k}": v for k, v in plant.items()}
    if seed is not None:
        out["plant.random"] = AROUND_ALL_AT_ONCE
        out["plant.seed"] = seed
    if careful:
        out.update(CAREFUL_CONTROLLER)
    if knows_latency and plant.get("actuation_delay_ms"):
        out["controller.lookahead_s"] = plant["actuation_delay_ms"] / 1000.0
    return out


__all__ = [
    "ALL_AT_ONCE",
    "ALL_BUT_ELASTIC",
    "ARM_OFF",
    "AROUND_ALL_AT_ONCE",
    "AROUND_REAL_MIX",
    "BEYOND_REACH",
    "BOUNDS",
    "BUMP",
    "CAREFUL_CONTROLLER",
    "ELASTIC",
    "HARD_PAPER",
    "ONE_AT_A_TIME",
    "PEN_OFF",
    "REAL_MIX",
    "REAL_WORLD",
    "SAFE_WITHIN_S",
    "WAVY_SHEET",
    "overrides",
]
