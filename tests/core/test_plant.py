"""The Plant protocol: typed commands, the kinds a plant takes, and the clocks."""

import numpy as np
import pytest

from inkarm.core.plant import (
    COMMANDS,
    SENSES,
    PenCommand,
    Plant,
    PlantState,
    PositionCommand,
    SimulatedClock,
    TorqueCommand,
    WallClock,
    unsupported,
)
from inkarm.errors import InputError


@pytest.fixture(scope="module")
def plant():
    from inkarm.sim.plant import MujocoPlant

    p = MujocoPlant()
    yield p
    p.close()


@pytest.mark.sim
def test_the_mujoco_plant_is_a_plant(plant):
    assert isinstance(plant, Plant)
    assert plant.commands <= COMMANDS and plant.senses <= SENSES
    assert "torque" in plant.commands and "force" in plant.senses
    state = plant.read()
    assert isinstance(state, PlantState)
    assert state.q.shape == (7,) and state.tip_mm.shape == (3,)
    assert state.force == 0.0 and state.pen_compression_mm == pytest.approx(0.0, abs=1e-9)


@pytest.mark.sim
@pytest.mark.parametrize(
    "command",
    [PenCommand(down=True)],
    ids=["pen"],
)
def test_the_mujoco_plant_refuses_commands_it_does_not_take(plant, command):
    before = plant.read()
    with pytest.raises(InputError, match=r"MujocoPlant does not take \w+ commands; it takes: "
                                         r"position, torque$"):
        plant.command(command)
    after = plant.read()
    assert after.time == before.time
    np.testing.assert_array_equal(after.torque, before.torque)


@pytest.mark.sim
def test_a_torque_command_is_held_over_a_step():
    from inkarm.sim.plant import MujocoPlant

    plant = MujocoPlant()
    tau = np.linspace(-1.0, 1.0, 7)
    plant.command(TorqueCommand(tau))
    plant.step()
    state = plant.read()
    assert state.time == pytest.approx(plant.dt)
    np.testing.assert_array_equal(state.torque, tau)
    plant.close()
    plant.close()  # idempotent
    np.testing.assert_array_equal(plant.read().torque, 0.0)


def test_unsupported_names_the_kind_and_what_is_taken():
    class Plotter:
        commands = frozenset({"position", "pen"})

    message = unsupported(Plotter(), TorqueCommand(np.zeros(2)))
    assert message == "Plotter does not take torque commands; it takes: pen, position"


def test_a_stand_in_with_the_members_is_a_plant_and_one_without_is_not():
    class Minimal:
        dt = 0.01
        senses = frozenset()
        commands = frozenset({"position"})

        def read(self):
            return PlantState(0.0, np.zeros(2), np.zeros(2))

        def command(self, command):
            pass

        def step(self):
            pass

        def close(self):
            pass

    assert isinstance(Minimal(), Plant)

    class Missing:
        dt = 0.01

        def read(self):
            pass

    assert not isinstance(Missing(), Plant)


def test_commands_are_frozen_values():
    command = PositionCommand(np.zeros(3))
    assert command.qd is None and command.qdd is None
    with pytest.raises(AttributeError):
        command.q = np.ones(3)  # type: ignore[misc]
    assert PenCommand(True).down


def test_the_wall_clock_waits_until_the_time():
    clock = WallClock()
    t0 = clock.now()
    assert t0 >= 0.0
    target = t0 + 0.02
    clock.wait_until(target)
    assert clock.now() >= target
    later = clock.now()
    clock.wait_until(later - 1.0)  # a time already past returns at once
    assert clock.now() >= later


def test_the_simulated_clock_moves_only_when_advanced():
    clock = SimulatedClock()
    assert clock.now() == 0.0
    clock.wait_until(0.5)
    assert clock.now() == 0.5
    clock.wait_until(0.2)  # never backwards
    assert clock.now() == 0.5
