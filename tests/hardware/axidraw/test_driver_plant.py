"""AxiDrawPlant without a device: the set-up it sends, the moves a stroke becomes, the timeline
it judges readings against (a move starts when answered or when the one before ends; the
1-deep FIFO's OK bounds the end of the move two before), and what is planned offline."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from inkarm.core.plant import PenCommand, PositionCommand
from inkarm.hardware.axidraw.placement import SheetPlacement
from inkarm.hardware.axidraw.plant import AxiDrawPlant
from inkarm.hardware.axidraw.profiles import load_profile

PROFILE = load_profile("v3")
SHEET = SheetPlacement((210.0, 297.0), (0.0, 0.0), PROFILE.travel_mm, "V3")


class ScriptedBus:
    """Answers OK (QS: the steps sent so far; QP: the pen; QB: not pressed; QM: idle) at the
    wall times ``replies`` give for motion commands, one after another."""

    version = (3, 0, 3)
    reply_timeout_s = 1.0

    def __init__(self, replies):
        self.sent: list[str] = []
        self.replies = list(replies)
        self.t = 0.0
        self.sent_at = self.replied_at = 0.0
        self.steps = [0, 0]
        self.up = True

    def clock(self):
        return self.t

    def transact(self, text, due_s=0.0):
        name = text.split(",")[0].strip()
        self.sent.append(text.strip())
        self.sent_at = self.t
        if name in ("SM", "SP"):
            self.t = max(self.t, self.replies.pop(0)) if self.replies else self.t
            if name == "SM":
                _, _, s1, s2 = text.strip().split(",")
                self.steps[0] += int(s1)
                self.steps[1] += int(s2)
            else:
                self.up = text.startswith("SP,1")
        self.replied_at = self.t
        self.t += 1e-6
        return {"QS": [f"{self.steps[0]},{self.steps[1]}"], "QP": ["1" if self.up else "0"],
                "QB": ["0"], "QM": ["QM,0,0,0,0"], "ES": ["0,0,0,0,0"]}.get(name, [])

    def drain(self, quiet_s=0.01):
        return []

    def close(self):
        pass


def test_the_set_up_is_the_axidraw_softwares():
    bus = ScriptedBus([0.0])
    AxiDrawPlant(bus, PROFILE, SHEET, poll_s=1e9)
    assert bus.sent == ["EM,1,1", "CS", "SC,4,20641", "SC,5,15248", "SC,11,1618", "SC,12,1079",
                        "SR,60000"]  # the pen-up SP is queued, sent with the first step()


def test_the_timeline_starts_moves_when_answered_and_the_fifo_bounds_their_ends():
    bus = ScriptedBus([])
    plant = AxiDrawPlant(bus, PROFILE, SHEET, poll_s=1e9)
    plant.command(PositionCommand(q=np.array([0.03, 0.27])))  # a travel from home
    moves = plant.motions
    assert moves[0].text == "SP,1,130\r" and moves[1].text.startswith("SM,")
    durations = np.array([m.duration_s for m in moves])
    # the device ran 5 ms ahead of the OK of its first command (it took it early); a 1-deep
    # FIFO answers move i when move i - 2 has ended, the first two at once
    real_end = np.cumsum(durations) - 0.005
    bus.replies = [0.0, 0.001] + list(real_end[:-2])
    plant.step()
    timeline_end = np.array([m.end for m in moves])
    assert np.allclose(timeline_end[:-2], real_end[:-2], atol=1e-5)
    assert np.all(np.diff([m.start for m in moves]) > 0)
    for a, b in itertools.pairwise(moves):
        assert b.start >= a.end - 1e-9  # one at a time
    # a device that is never ahead leaves the timeline as answered: SP at 0, SM1 after it
    bus2 = ScriptedBus([])
    plant2 = AxiDrawPlant(bus2, PROFILE, SHEET, poll_s=1e9)
    plant2.command(PositionCommand(q=np.array([0.03, 0.27])))
    bus2.replies = [0.0, 0.001] + list(np.cumsum(durations)[:-2] + 0.0002)
    plant2.step()
    assert plant2.motions[0].start == pytest.approx(0.0, abs=1e-5)
    assert plant2.motions[1].start == pytest.approx(0.13, abs=1e-5)
    ends, plan = plant2.schedule()
    assert ends[0] == pytest.approx(plant2.motions[-1].end)
    assert np.all(np.diff(plan.samples[:, 0]) >= -1e-9)


def test_a_stroke_is_planned_when_the_pen_lifts_and_its_rows_end_in_order():
    bus = ScriptedBus([])
    plant = AxiDrawPlant(bus, PROFILE, SHEET, poll_s=1e9)
    plant.command(PositionCommand(q=np.array([0.05, 0.2])))
    plant.command(PenCommand(down=True))
    t = np.linspace(0, 1, 60)
    pts = np.c_[50 + 20 * t, 200 + 5 * np.sin(6 * t)] / 1000.0
    for k in range(1, len(pts)):
        plant.command(PositionCommand(q=pts[k], qd=(pts[k] - pts[k - 1]) / 0.02))
    assert plant.pending and plant.command_motion[-1] == -2  # gathered, not planned yet
    plant.command(PenCommand(down=False))
    assert not plant.pending
    assert plant.finish()
    ends, _ = plant.schedule()
    assert np.all(np.diff(ends) >= -1e-9) and ends[-1] == pytest.approx(plant.motions[-1].end)
    texts = [m.text.strip() for m in plant.motions]
    assert texts[0] == "SP,1,130" and "SP,0,146" in texts and texts[-1] == "SP,1,130"
    assert tuple(bus.steps) == plant.cursor.steps == plant.cursor.target(
        SHEET.to_machine(pts[-1] * 1000.0))
    readings = plant.readings()
    assert readings and np.allclose(readings[-1].q * 1000.0, SHEET.to_page(
        plant.cursor.position_mm()))
    plant.close()
    tail = bus.sent[max(i for i, c in enumerate(bus.sent) if c == "SP,1,130"):]
    assert tail[-1] == "EM,0,0" and any(c.startswith("SM,") for c in tail)  # pen up, home, off


def test_lost_steps_fail_the_job():
    bus = ScriptedBus([])
    plant = AxiDrawPlant(bus, PROFILE, SHEET, poll_s=1e9)
    plant.command(PositionCommand(q=np.array([0.02, 0.28])))
    plant.step()
    bus.steps[0] -= 3  # the counters disagree with what was sent
    assert not plant.finish()
    assert "step counters read" in plant.failure and "steps were lost" in plant.failure
    plant.close()
    assert "ES" in bus.sent and bus.sent[-1] == "EM,0,0"


def test_a_command_beyond_the_travel_is_refused_by_the_plant():
    plant = AxiDrawPlant(None, PROFILE, SHEET)
    with pytest.raises(Exception, match="beyond the AxiDraw V3's travel"):
        plant.command(PositionCommand(q=np.array([0.05, 0.01])))  # page y 10: machine y 287
