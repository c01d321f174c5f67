"""Control laws as objects: the registry and its errors, a scenario's `[controller] law`, the
0.2 `command` key, a user's law run by the one executor, and N >= 1 members of one execution
(bit for bit as alone; a fault or Ctrl-C in one member)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from inkarm.control.executor import execute, run_drawing
from inkarm.control.laws import LAWS, LawContext, LawSpec, Setpoint, law_class, make_law
from inkarm.control.laws.position_goals import PositionGoals
from inkarm.control.members import Solo
from inkarm.core.log import LIFT
from inkarm.core.plant import PositionCommand, TorqueCommand
from inkarm.errors import InputError, RunFault, ScenarioError
from inkarm.jobs.scenario import load_scenario, parse_scenario

QUICK = "scenarios/quick_stroke.toml"


class Recording(PositionGoals):
    """A user's law that is the built-in position law, recording what the executor gives it."""

    def __init__(self, **settings):
        super().__init__(**settings)
        self.contexts: list[LawContext] = []
        self.setpoints: list[Setpoint] = []

    def start(self, context):
        self.contexts.append(context)
        super().start(context)

    def command(self, state, setpoint):
        self.setpoints.append(setpoint)
        return super().command(state, setpoint)


class NotALaw:
    commands = frozenset({"velocity"})

    def start(self, context):
        pass

    def command(self, state, setpoint):
        pass


class Interrupting(PositionGoals):
    """Presses Ctrl-C at its 40th period."""

    def start(self, context):
        super().start(context)
        self.periods = 0

    def command(self, state, setpoint):
        self.periods += 1
        if self.periods == 40:
            raise KeyboardInterrupt
        return super().command(state, setpoint)


@pytest.fixture(scope="module")
def quick():
    return load_scenario(QUICK)


def test_the_built_ins_are_registered_with_what_they_send():
    assert {"position", "joint_pid"} <= set(LAWS.names())
    assert law_class("position").commands == frozenset({"position"})
    assert law_class("joint_pid").commands == frozenset({"torque"})
    assert LawSpec().name == "position" and LawSpec("joint_pid").commands == {"torque"}


@pytest.mark.parametrize("name, settings, message, key", [
    ("positon", {}, r"unknown law 'positon' \(did you mean 'position'\?\); expected one of",
     "controller.law"),
    ("no_such_module_xyz:Law", {}, r"cannot import module 'no_such_module_xyz'",
     "controller.law"),
    ("tests.control.test_laws:Missing", {}, r"has no attribute 'Missing'", "controller.law"),
    ("tests.control.test_laws:QUICK", {}, (r"is not a control law: a law is a class with "
     r"commands, start\(context\) and command\(state, setpoint\)"), "controller.law"),
    ("tests.control.test_laws:NotALaw", {}, (r"declares commands \['velocity'\]; expected a "
     r"non-empty subset of \['position', 'torque'\]"), "controller.law"),
    ("position", {"friction": 1.0}, (r"^controller.position.friction: law 'position' has no "
     r"setting 'friction' \(did you mean 'friction_adaptation'\?\); its settings: "
     r"friction_adaptation$"), "controller.position.friction"),
    ("position", {"friction_adaptaton": 1.0}, (r"no setting 'friction_adaptaton' \(did you "
     r"mean 'friction_adaptation'\?\)"), "controller.position.friction_adaptaton"),
    ("position", {"friction_adaptation": -1.0}, (r"friction_adaptation: expected a rate in "
     r"\[0, 1e9\)"), "controller.position"),
])
def test_a_bad_law_is_refused_naming_the_key(name, settings, message, key):
    with pytest.raises(InputError, match=message) as info:
        make_law(name, settings)
    assert info.value.key == key


def test_a_scenario_names_its_law_and_settings_and_they_round_trip(quick):
    # (a dotted override cannot name a table called by an import path: the whole table)
    scenario = quick.with_overrides({"controller": {
        "go_home": False, "law": "tests.control.test_laws:Recording",
        "tests.control.test_laws:Recording": {"friction_adaptation": 0.0}}})
    assert scenario.law == LawSpec("tests.control.test_laws:Recording",
                                   (("friction_adaptation", 0.0),))
    table = scenario.to_dict()["controller"]
    assert table["law"] == "tests.control.test_laws:Recording"
    assert table["tests.control.test_laws:Recording"] == {"friction_adaptation": 0.0}
    assert scenario.with_overrides({}).law == scenario.law
    with pytest.raises(InputError, match=r"quick_stroke.toml \(with overrides\): "
                                            r"controller.position.frict: law 'position' "
                                            r"has no setting 'frict'"):
        quick.with_overrides({"controller.position": {"frict": 1.0}})


def test_the_old_command_key_still_works_with_a_warning(quick):
    data = {"source": {"kind": "text", "text": "a"}, "controller": {"command": "torque"}}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scenario = parse_scenario(data, source="old.toml")
    assert scenario.law == LawSpec("joint_pid")
    assert [str(w.message) for w in caught] == [
        ("old.toml: controller.command = 'torque' is deprecated and goes in the next release; "
        "write controller.law = 'joint_pid'")]
    with pytest.raises(ScenarioError, match="controller.command: give law only"):
        parse_scenario({**data, "controller": {"command": "torque", "law": "position"}},
                       source="old.toml")
    with pytest.raises(ScenarioError, match=r"controller.command: .*'velocity'"):
        parse_scenario({**data, "controller": {"command": "velocity"}}, source="old.toml")


@pytest.mark.sim
def test_a_users_law_is_driven_like_a_built_in_bit_for_bit(quick):
    """The executor never branches on the law: a user's subclass of the built-in gets the
    context and a setpoint every period, and draws exactly what the built-in draws."""
    from inkarm.jobs.run import run

    built_in = run(quick)
    Recording.last = None
    user = run(quick.with_overrides({"controller.law": "tests.control.test_laws:Recording"}))
    assert user.status == built_in.status == "ok"
    assert np.array_equal(user.log.q, built_in.log.q)
    assert np.array_equal(user.log.force, built_in.log.force)
    assert np.array_equal(user.canvas.image, built_in.canvas.image)


@pytest.mark.sim
def test_the_law_gets_the_plan_and_one_setpoint_per_period(quick):
    from inkarm.jobs.preflight import placed_within_budget
    from inkarm.sim.cell import Cell, build_model, kinematic_model
    from inkarm.sim.plant import MujocoPlant

    cell = Cell(quick.cell, quick.robot)
    drawing = placed_within_budget(quick, cell)
    believed = kinematic_model(cell)
    plant = MujocoPlant(build_model(cell), cell=cell, drive_gains=quick.robot.drive)
    law = Recording()
    [log] = execute(drawing, plant, believed, quick.robot.gains, quick.controller,
                    law=_Fixed(law))
    [context] = law.contexts
    assert context.dt == plant.dt and context.senses == plant.senses
    assert len(context.plan) > 0 and context.gains is quick.robot.gains
    assert len(law.setpoints) == len(log)
    rows = [s.row for s in law.setpoints]
    assert rows == sorted(rows) and rows[-1] == len(context.plan) - 1
    assert any(s.pressing for s in law.setpoints) and not any(s.stopping for s in law.setpoints)
    pressing = [s for s in law.setpoints if s.pressing]
    assert all(np.array_equal(s.q, s.q_row) for s in pressing)  # no actuation lead set


class _Fixed(LawSpec):
    """A spec that hands out one given instance (to look into it after the run)."""

    def __init__(self, law):
        object.__setattr__(self, "name", "tests.control.test_laws:Recording")
        object.__setattr__(self, "settings", ())
        object.__setattr__(self, "law", law)

    def make(self):
        return self.law


class _Faulting:
    """Two simulated arms stepped together; member 1's step faults at a given period."""

    def __init__(self, plants, fault_at: int):
        self.plants = plants
        self.dt = plants[0].dt
        self.fault_at = fault_at
        self.steps = 0

    def now(self):
        return self.plants[0].now()

    def step(self, members):
        self.steps += 1
        faults = {}
        for m in members:
            self.plants[m].step()
            if m == 1 and self.steps == self.fault_at:
                faults[m] = RunFault("device: the servo overheated", watchdog="device",
                                     time_s=self.plants[m].now())
        return faults


def _two_arms(quick):
    from inkarm.jobs.preflight import placed_within_budget
    from inkarm.sim.cell import Cell, build_model, kinematic_model
    from inkarm.sim.plant import MujocoPlant

    cell = Cell(quick.cell, quick.robot)
    plants = [MujocoPlant(build_model(cell), cell=cell, drive_gains=quick.robot.drive)
              for _ in range(2)]
    return placed_within_budget(quick, cell), plants, kinematic_model(cell)


@pytest.mark.sim
def test_a_member_whose_plant_faults_is_lifted_and_the_other_draws_on_as_alone(quick):
    drawing, plants, believed = _two_arms(quick)
    ok, failed = execute(drawing, _Faulting(plants, 60), believed, quick.robot.gains,
                         quick.controller)
    alone = run_drawing(drawing, _two_arms(quick)[1][0], believed, quick.robot.gains,
                        quick.controller)
    assert np.array_equal(ok.q, alone.q) and np.array_equal(ok.force, alone.force)
    assert isinstance(failed, RunFault) and str(failed).startswith("device: the servo")
    stop = failed.log.phase == LIFT
    assert stop[-1] and len(failed.log) < len(ok)
    # lifted over stop_s and held half as long again: 1.5 x stop_s of periods after the fault
    ticks = max(1, round(quick.controller.stop_s / plants[0].dt))
    assert int(np.argmax(stop)) == 60 and stop.sum() == ticks + ticks // 2
    assert failed.log.force[-1] == 0.0  # the pen off the paper


@pytest.mark.sim
def test_ctrl_c_in_one_member_lifts_every_member_and_keeps_their_logs(quick):
    drawing, plants, believed = _two_arms(quick)
    members = Solo(plants[0])
    members.plants = tuple(plants)  # (two plants, each stepped by hand below)
    members.step = lambda ids: {m: f for m in ids for f in [_step(plants[m])] if f}
    with pytest.raises(KeyboardInterrupt) as info:
        execute(drawing, members, believed, quick.robot.gains, quick.controller,
                law=LawSpec("tests.control.test_laws:Interrupting"))
    logs = info.value.logs
    assert len(logs) == 2 and info.value.log is logs[0]
    for log in logs:
        assert log.phase[-1] == LIFT and len(log) < 100


def _step(plant):
    plant.step()


@pytest.mark.sim
def test_members_must_start_at_one_pose(quick):
    drawing, plants, believed = _two_arms(quick)
    plants[1].data.qpos[0] += 0.1
    with pytest.raises(InputError, match="must start at the same pose"):
        execute(drawing, _Faulting(plants, 0), believed, quick.robot.gains, quick.controller)


def test_commands_are_typed():
    q = np.zeros(2)
    assert PositionCommand(q).qd is None and TorqueCommand(q).torque is q


class Broken(PositionGoals):
    """A user's law with a bug at its 50th period."""

    def start(self, context):
        super().start(context)
        self.periods = 0

    def command(self, state, setpoint):
        self.periods += 1
        if self.periods == 50:
            return 1 / 0
        return super().command(state, setpoint)


@pytest.mark.sim
def test_a_law_that_raises_fails_its_run_with_the_pen_lifted_and_the_log_kept(quick):
    from inkarm.jobs.run import run

    failed = run(quick.with_overrides({"controller.law": "tests.control.test_laws:Broken"}))
    assert failed.status == "failed"
    assert failed.reason.startswith("law_error: the control law raised ZeroDivisionError: "
                                    "division by zero at t = ")
    assert failed.log.phase[-1] == LIFT and failed.log.force[-1] == 0.0
    assert len(failed.log) == 49 + 15  # its 49 periods, then the built-in law's lift and hold
    assert np.all(np.diff(failed.log.time) > 0)  # one row a period


@pytest.mark.sim
def test_a_law_that_raises_in_one_member_leaves_the_others_drawing(quick):
    drawing, plants, believed = _two_arms(quick)

    class OneBroken(LawSpec):  # member 1's law is the broken one
        def make(self, made=[]):  # noqa: B006 (counts the members made)
            made.append(1)
            return Broken() if len(made) == 2 else PositionGoals()

    ok, failed = execute(drawing, _Faulting(plants, 0), believed, quick.robot.gains,
                         quick.controller, law=OneBroken("position"))
    assert isinstance(ok, type(run_drawing(drawing, _two_arms(quick)[1][0], believed,
                                           quick.robot.gains, quick.controller)))
    assert isinstance(failed, RunFault) and failed.watchdog == "law_error"


@pytest.mark.sim
def test_a_watchdog_fault_logs_one_row_a_period_and_commands_once_a_period(quick):
    from inkarm.jobs.run import run

    failed = run(quick.with_overrides({"controller.tracking_limit_mm": 0.001,
                                       "controller.watchdog_s": 0.006}))
    assert failed.status == "failed" and failed.reason.startswith("tracking_limit")
    assert np.all(np.diff(failed.log.time) > 0)


@pytest.mark.sim
def test_ctrl_c_while_a_member_lifts_after_its_fault_keeps_both_logs(quick):
    drawing, plants, believed = _two_arms(quick)
    members = _Faulting(plants, 50)
    step = members.step

    def interrupting(ids):
        if members.steps == 53:
            raise KeyboardInterrupt
        return step(ids)

    members.step = interrupting
    with pytest.raises(KeyboardInterrupt) as info:
        execute(drawing, members, believed, quick.robot.gains, quick.controller)
    faulted, interrupted = info.value.logs
    ticks = max(1, round(quick.controller.stop_s / plants[0].dt))
    # the faulted member finished its whole lift (it was not told again), the other lifted too
    assert faulted is not None and (faulted.phase == LIFT).sum() == ticks + ticks // 2
    assert interrupted is not None and interrupted.phase[-1] == LIFT


def test_switching_the_law_leaves_the_old_laws_settings_behind(quick):
    tuned = quick.with_overrides({"controller.law": "joint_pid"}).with_overrides(
        {"controller.law": "tests.control.test_laws:Recording",
         'controller."tests.control.test_laws:Recording".friction_adaptation': 0.0})
    assert tuned.law == LawSpec("tests.control.test_laws:Recording",
                                (("friction_adaptation", 0.0),))
    assert tuned.with_overrides({"controller.law": "position"}).law == LawSpec("position")
    with pytest.raises(InputError, match=r"controller.impedance: settings of 'impedance', "
                                         r"which this scenario does not use \(law = 'position'"):
        quick.with_overrides({"controller.impedance": {"stiffness_n_per_mm": 3.0}})
    with pytest.raises(InputError, match=r"controller.watchdogs: each watchdog once: "
                                         r"force_limit is listed more than once"):
        quick.with_overrides({"controller.watchdogs": ["force_limit", "force_limit"]})
    with pytest.raises(InputError, match=r"overrides: controller.\"a.b: expected a dotted key"):
        quick.with_overrides({'controller."a.b': 1.0})
