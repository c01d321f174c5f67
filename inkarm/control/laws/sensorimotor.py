"""``sensorimotor``: seed 001's synthesis (sec. 4-5): discrete DPPLA targets are the commands, a
learnt local inverse of the kinematics moves the pen toward the current one, a joint PID closes
the loop; the path emerges from the loop.

Targets (:func:`dppla_targets`). Before the run, each stroke of the planned pen path
(``plan.page_mm`` over the stroke's drawing rows) is reduced by DPPLA (seed 001, sec. 3;
:func:`inkarm.analysis.dppla.dppla`, time as the chord parameter) at the compression rate
``compression`` (0.85, the rate of the seed's sec. 5): its targets X(n_i) with their time stamps
t_i = n_i dt. Only these reach the loop: not the path between them, nor its speed. The first
target is where the stroke starts, the last where it ends.

Kinematic inversion, every period of a stroke (seed 001, sec. 4: the mapping (y, dx) -> dy with
y = q). With the pen at x (page [mm]), the current target x_j (the first of the stroke whose time
stamp is still ahead), the time to go T = t_j - t and the gain g = ``gain_per_s``:

    dx_page = min(1 / T, g) (x_j - x) dt          in the paper's plane: reach x_j at t_j, and
                                                  close in at the rate g over the last 1/g s
    dx      = [R_page dx_page + e_n n ; e_tilt]   the 5-D pen task (tip [m], two tilts)
    dq      = B(q_goal) dx                        ``inverse = "lwr"``: the local inverse learnt
                                                  from babbling (:mod:`inkarm.control.lwr`);
                                                  ``"jacobian"``: J5^+ dx, the analytic
                                                  Jacobian's pseudo-inverse, for comparison
    q_goal <- q_goal + dq

where e_n (the goal's tip above the plan's pressed depth, along the paper normal) and e_tilt (the
pen's tilt) are removed each period: the loop steers the pen in the paper's plane and keeps it
pressed and perpendicular. q_goal starts at the plan's pose at the stroke's first row.

Where x comes from: the pen of the goal pose on the controller's model, x = FK(q_goal), an
efference copy; the plant's own sensing enters through the PID (q, qd) and the force loop (F).
Closing this loop on the sensed tip instead (x = the plant's tip) puts an integrator, q_goal,
around the PID's lag: on the default letter that grew into an 8 Hz oscillation and a tracking
fault at every g from 10 to 30 /s (measured while writing this law), so the seed's "continuous
use of sensory data" is here the joint and force feedback.

Dynamics inversion (seed 001, sec. 4: "a Proportional Integrative Derivative model"): the joint
PID of :class:`inkarm.control.pid.JointPID` with the profile's gains, sending torques,

    tau = PID(q_goal + d n_q - q, dq/dt - qd) + c(q, qd) + F tanh(dq/dt / w) [+ J^T f pressing]

with the force loop's depth d along the paper normal (``setpoint.depth``, through the plan's
``normal_q``), gravity and Coriolis compensation c on the controller's model at the measured
state, the model's dry joint friction F (``friction_compensation``; the seed's simulated arm had
none; fixed, as in :mod:`inkarm.control.friction` without adaptation) and the planned contact
force. No inertial feed-forward: the seed's PID "cannot adjust the dynamical parameters during
the course of the motion", which is where its Fig. 3's overshoot at high curvature comes from.
Why torques rather than position goals to the drives: the seed's dynamics inversion is that PID,
and a drive's stiff loop with feed-forward would hide the dynamics whose effect Fig. 3 shows;
the simulated arm takes torques (as servos in current mode do).

Outside the strokes (approach, descend, lift, travel, home, a safe stop) the law is
``joint_pid``: the PID on the shaped setpoint with the plan's feed-forward. When a stroke ends,
the goal's offset from the plan's last pose fades out over ``release_s``.

Babbling (:func:`inkarm.control.lwr.babble`), in :meth:`Sensorimotor.start`:
``babbling_samples`` random joint motions of ``babbling_rad`` from poses spread
``bandwidth_rad / 2`` about the plan's drawing poses, on the controller's own kinematic model,
seeded by ``seed``; the local inverse's kernel has the bandwidth ``bandwidth_rad``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from inkarm.analysis.dppla import EXACT_BUDGET, dppla, segments_for_compression
from inkarm.control.friction import FrictionCompensation
from inkarm.control.ik import pen_jacobian
from inkarm.control.laws import LawContext, Setpoint
from inkarm.control.lwr import LocalInverse, babble, pen_output, pseudo_inverse_step
from inkarm.control.pid import JointPID
from inkarm.core.log import DRAW
from inkarm.core.plant import PlantState, TorqueCommand
from inkarm.errors import InputError, unknown_name

INVERSES = ("lwr", "jacobian")
MAX_CENTRES = 60
"""Most drawing poses the babbling is spread around (evenly along the drawing rows)."""
MAX_STEP_RAD = 0.05
"""Largest joint step of q_goal in one period [rad] (a guard: the steps are ~1e-3)."""


@dataclass(frozen=True, eq=False)
class Targets:
    """The DPPLA targets of a plan's strokes (:func:`dppla_targets`).

    Attributes:
        row: Plan row of each target (m,): its time stamp is ``row * dt``.
        xy: Target positions in page [mm], (m, 2).
        stroke: Stroke of each target (m,).
        active: Per plan row (K,), the index of the target the loop heads for: the first of the
            row's stroke whose row is after it (the stroke's last at its last row); -1 outside
            the drawing rows.
    """

    row: np.ndarray
    xy: np.ndarray
    stroke: np.ndarray
    active: np.ndarray

    def __len__(self) -> int:
        return len(self.row)


def stroke_rows(phase: np.ndarray, stroke: np.ndarray) -> list[np.ndarray]:
    """The drawing rows of each stroke (consecutive runs of ``phase == DRAW``), in order."""
    draw = np.asarray(phase) == DRAW
    if not draw.any():
        return []
    edges = np.flatnonzero(np.diff(np.r_[0, draw.astype(np.int8), 0]))
    runs = [np.arange(a, b) for a, b in zip(edges[::2], edges[1::2])]
    # (a stroke is one run: a run that continues the previous run's stroke joins it)
    out: list[np.ndarray] = []
    for run in runs:
        if out and stroke[out[-1][-1]] == stroke[run[0]] and out[-1][-1] + 1 == run[0]:
            out[-1] = np.r_[out[-1], run]
        else:
            out.append(run)
    return out


def dppla_targets(page_mm: np.ndarray, phase: np.ndarray, stroke: np.ndarray,
                  compression: float) -> Targets:
    """DPPLA targets (seed 001, sec. 3) of each stroke of a planned path: the drawing rows'
    page positions ``page_mm[:, :2]`` at the compression rate ``compression`` (the row index,
    i.e. time, as the chord parameter). Strokes of fewer than 3 rows keep their two ends."""
    page_mm = np.asarray(page_mm, dtype=float)
    stroke = np.asarray(stroke)
    rows_, strokes_ = [], []
    for rows in stroke_rows(phase, stroke):
        xy = page_mm[rows, :2]
        w = len(rows)
        if w < 3:
            picks = np.unique([0, w - 1])
        else:
            k = segments_for_compression(compression, w, 2)
            picks = dppla(xy, k, banded=k * w * w / 2 > EXACT_BUDGET, verify=False).breakpoints
        rows_.append(rows[picks])
        strokes_.append(np.full(len(picks), stroke[rows[0]]))
    row = np.concatenate(rows_) if rows_ else np.zeros(0, dtype=np.intp)
    active = np.full(len(page_mm), -1, dtype=np.intp)
    first = 0
    for picks in rows_:
        seg = np.arange(picks[0], picks[-1] + 1)
        # the first target of the stroke with its row after the current one
        ahead = np.searchsorted(picks, seg, side="right")
        active[seg] = first + np.minimum(ahead, len(picks) - 1)
        first += len(picks)
    return Targets(row.astype(np.intp), page_mm[row, :2].copy(),
                   np.concatenate(strokes_) if strokes_ else np.zeros(0, dtype=np.intp), active)


def _number(name: str, value, unit: str, low: float, high: float, *, integer: bool = False,
            low_open: bool = True):
    """``value`` if it is a number (an integer when ``integer``) in its range; else an
    InputError naming the setting (the registry prefixes ``controller.sensorimotor``)."""
    kinds = (int, np.integer) if integer else (int, float, np.integer, np.floating)
    ok = (isinstance(value, kinds) and not isinstance(value, bool) and math.isfinite(value)
          and (low < value if low_open else low <= value) and value <= high)
    if not ok:
        kind = "an integer" if integer else "a number"
        bracket = "(" if low_open else "["
        raise InputError(f"expected {kind} in {bracket}{low:g}, {high:g}]{' ' + unit if unit else ''}"
                         f", got {value!r}", key=name, value=value)
    return int(value) if integer else float(value)


class Sensorimotor:
    """Seed 001's sensory-motor synthesis as a control law (module docstring).

    Args:
        inverse: "lwr": the local inverse learnt by locally weighted regression on babbling
            (the seed's); "jacobian": the analytic Jacobian's pseudo-inverse (the comparison).
        compression: DPPLA compression rate rho in (0, 1) of the planned strokes (seed 001,
            sec. 3): fewer targets as it rises (0.85: about 17 targets a second at 6 ms).
        gain_per_s: g, the highest rate at which the target error is removed [1/s].
        babbling_samples: N, the random joint motions of the babbling.
        babbling_rad: Their size (standard deviation per joint) [rad].
        bandwidth_rad: h, the kernel bandwidth of the local inverse in joint space [rad].
        release_s: How long the goal's offset from the plan fades out after a stroke [s].
        friction_compensation: Add the model's dry joint friction to the feed-forward.
        seed: Seed of the babbling.
    """

    commands = frozenset({"torque"})

    def __init__(self, inverse: str = "lwr", compression: float = 0.85,
                 gain_per_s: float = 30.0, babbling_samples: int = 2000,
                 babbling_rad: float = 0.005, bandwidth_rad: float = 0.03,
                 release_s: float = 0.05, friction_compensation: bool = True, seed: int = 0):
        if inverse not in INVERSES:
            raise unknown_name("inverse", inverse, INVERSES, key="inverse")
        if not (isinstance(compression, (int, float)) and not isinstance(compression, bool)
                and 0.0 < compression < 1.0):
            raise InputError(f"expected a DPPLA compression rate in (0, 1), got {compression!r}",
                             key="compression", value=compression)
        if not isinstance(friction_compensation, bool):
            raise InputError(f"expected true or false, got {friction_compensation!r}",
                             key="friction_compensation", value=friction_compensation)
        self.inverse = inverse
        self.compression = float(compression)
        self.gain_per_s = _number("gain_per_s", gain_per_s, "1/s", 0.0, 1e4)
        self.babbling_samples = _number("babbling_samples", babbling_samples, "", 20, 1e6,
                                        integer=True, low_open=False)
        self.babbling_rad = _number("babbling_rad", babbling_rad, "rad", 0.0, 0.1)
        self.bandwidth_rad = _number("bandwidth_rad", bandwidth_rad, "rad", 0.0, 2.0)
        self.release_s = _number("release_s", release_s, "s", 0.0, 10.0, low_open=False)
        self.friction_compensation = friction_compensation
        self.seed = _number("seed", seed, "", 0, 2**32 - 1, integer=True, low_open=False)

    def start(self, context: LawContext) -> None:
        plan, kin = context.plan, context.kinematics
        self.dt = context.dt
        self.pid = JointPID(context.gains, context.dt)
        self.kin = kin
        self.bias = kin.bias
        self.inertia, self.contact_tau = plan.inertia, plan.contact_tau
        self.plan_q, self.normal_q = plan.q, plan.normal_q
        self.plan_z = plan.page_mm[:, 2].tolist()
        self.placement = placement = context.model.placement
        self.origin = placement.origin_m
        self.to_robot = placement.rotation / 1000.0  # page [mm] -> robot [m] (a direction)
        self.to_page = placement.rotation.T * 1000.0  # robot [m] -> page [mm]
        self.axis = placement.pen_axis
        self.friction = (kin.model.dof_frictionloss[kin.dof_adr].copy()
                         if self.friction_compensation else None)
        self.targets = dppla_targets(plan.page_mm, plan.phase, plan.stroke, self.compression)
        self.active = self.targets.active.tolist()
        self.target_row = self.targets.row.tolist()
        self.target_xy = self.targets.xy
        self.model = None
        if self.inverse == "lwr" and len(self.targets):
            drawing = np.flatnonzero(self.targets.active >= 0)
            picks = drawing[np.linspace(0, len(drawing) - 1,
                                        min(MAX_CENTRES, len(drawing))).round().astype(int)]
            data = babble(kin, plan.q[picks], self.axis, self.babbling_samples,
                          self.babbling_rad, 0.5 * self.bandwidth_rad, self.seed)
            self.model = LocalInverse(data, self.bandwidth_rad)
        self.q_goal: np.ndarray | None = None  # the integrated goal while drawing
        self.last_row = 0
        self.offset: np.ndarray | None = None  # the goal's offset from the plan after a stroke
        self.release_rows = max(1, round(self.release_s / self.dt))
        self.released = 0

    def step(self, q_goal: np.ndarray, c: int, j: int) -> np.ndarray:
        """dq of the module docstring from the goal ``q_goal`` at plan row ``c``, heading for
        target ``j``."""
        kin, dt = self.kin, self.dt
        if self.model is None:
            p, R, Jp, Jr = kin.jacobian_views(q_goal)
            J = pen_jacobian(R, Jp, Jr)
        else:
            p, R = kin.fk(q_goal)
        x = pen_output(R, p, self.axis)
        page = self.to_page @ (p - self.origin)  # the goal's pen on the page [mm]
        to_go = (self.target_row[j] - c) * dt
        g = self.gain_per_s
        rate = g if to_go * g <= 1.0 else 1.0 / to_go
        target = self.target_xy[j]
        dx = np.empty(5)
        dx[:3] = self.to_robot @ np.array([(target[0] - page[0]) * rate * dt,
                                           (target[1] - page[1]) * rate * dt,
                                           self.plan_z[c] - page[2]])
        dx[3:] = -x[3:]
        dq = pseudo_inverse_step(J, dx) if self.model is None else self.model.predict(q_goal, dx)
        biggest = max(map(abs, dq.tolist()))
        if biggest > MAX_STEP_RAD:
            dq *= MAX_STEP_RAD / biggest
        return dq

    def command(self, state: PlantState, setpoint: Setpoint) -> TorqueCommand:
        q, qd = state.q, state.qd
        feedforward = self.bias(q, qd).copy()
        c = setpoint.row
        j = -1 if setpoint.stopping else self.active[c]
        if j < 0:  # outside the strokes: joint_pid on the setpoint
            goal, goal_qd = setpoint.q, setpoint.qd
            if self.q_goal is not None:  # a stroke just ended: release the goal's offset
                self.offset = self.q_goal - self.plan_q[self.last_row]
                self.q_goal, self.released = None, 0
            if self.offset is not None and not setpoint.stopping:
                self.released += 1
                fade = 1.0 - self.released / self.release_rows
                if fade <= 0.0:
                    self.offset = None
                else:
                    goal = goal + fade * self.offset
                    goal_qd = goal_qd - self.offset / (self.release_rows * self.dt)
            if not setpoint.stopping:
                feedforward += self.inertia[c]
                if setpoint.pressing:
                    feedforward += self.contact_tau[c]
            return TorqueCommand(self.pid.update(goal, q, qd, goal_qd, feedforward))
        if self.q_goal is None:  # the stroke starts where the plan puts it
            self.q_goal = self.plan_q[c].copy()
            self.offset = None
        dq = self.step(self.q_goal, c, j)
        self.q_goal = np.minimum(np.maximum(self.q_goal + dq, self.kin.lower), self.kin.upper)
        self.last_row = c
        goal_qd = dq / self.dt
        if self.friction is not None:
            feedforward += self.friction * FrictionCompensation.direction(goal_qd)
        if setpoint.pressing:
            feedforward += self.contact_tau[c]
        return TorqueCommand(self.pid.update(self.q_goal + setpoint.depth * self.normal_q[c],
                                             q, qd, goal_qd, feedforward))


__all__ = ["INVERSES", "Sensorimotor", "Targets", "dppla_targets", "stroke_rows"]
