"""A Dynamixel Protocol 2.0 bus on a pseudo-terminal, for the real dynamixel-sdk to talk to.

The parts: :mod:`.protocol` (CRC-16, stuffing, framing), :mod:`.memory` (control-table memory
and its access rules), :mod:`.instructions` (what each instruction does and who answers),
:mod:`.physics` (servo firmware on injected joints). This module serves them on a pty:

* Timing at the set baud rate: a reply starts after the request's last byte (10 bits a byte)
  plus the servo's Return Delay Time (2 us units), and is written once its last byte would
  have left the wire; servos answering one SYNC/BULK read follow each other.
* Simulated time is locked to wall time: between packets, at least every period, the
  physics is advanced to now (at most :data:`MAX_CATCH_UP_S` at once; the rest is dropped
  and counted); a packet is answered from the latest state.
* Faults on command (:class:`Fault`, timed from the host's first torque-on: the first
  write of Torque Enable = 1, so servos that boot holding, as the twin's do, start no clock
  before a driver connects):
  ``silent`` (no replies), ``crc`` (corrupt CRC), ``late`` (each reply 100 ms late, sent
  while the bus goes on),
  ``overload`` and ``overheat`` (hardware errors: torque off, alert bit), ``watchdog`` (the
  servo's bus watchdog fires), ``disconnect`` (the port closes).
"""

from __future__ import annotations

import os
import select
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Self

import numpy as np

from inkarm.errors import InputError, unknown_name
from inkarm.hardware.dynamixel import protocol as p
from inkarm.hardware.dynamixel.instructions import EmulatedBus, EmulatedServo
from inkarm.hardware.dynamixel.physics import JointPhysics, Mount, ServoBank, SimpleJoints
from inkarm.hardware.dynamixel.tables import BAUD_RATES, table
from inkarm.hardware.pty import close_quietly, open_raw_pty

MAX_CATCH_UP_S = 0.05
FAULT_KINDS = ("silent", "crc", "late", "overload", "overheat", "watchdog", "disconnect")
LATE_S = 0.1


@dataclass(frozen=True)
class Fault:
    """Inject ``kind`` into servo ``servo_id`` ``at_s`` seconds after the host's first
    torque-on (module docstring)."""

    kind: str
    servo_id: int = 1
    at_s: float = 0.0

    def __post_init__(self):
        if self.kind not in FAULT_KINDS:
            raise unknown_name("fault", self.kind, FAULT_KINDS, key="--fault")


def parse_fault(text: str) -> Fault:
    """``KIND:ID:AT_S`` (e.g. ``overload:4:1.5``) -> :class:`Fault`."""
    parts = text.split(":")
    try:
        kind = parts[0]
        servo_id = int(parts[1]) if len(parts) > 1 else 1
        at_s = float(parts[2]) if len(parts) > 2 else 0.0
    except ValueError:
        raise InputError(f"expected KIND:ID:SECONDS (e.g. overload:4:1.5), got {text!r}",
                         key="--fault", value=text) from None
    if len(parts) > 3 or not (0 <= servo_id <= 252) or not (0 <= at_s < 1e6):
        raise InputError(f"expected KIND:ID:SECONDS with ID in 0..252, got {text!r}",
                         key="--fault", value=text)
    return Fault(kind, servo_id, at_s)


@dataclass(frozen=True)
class ServoSpec:
    """One servo to emulate: id, model, the joint it drives and how it is mounted."""

    servo_id: int
    model: str
    mount: Mount
    secondary_id: int = 255
    reverse: bool = False


@dataclass
class EmulatorStats:
    packets: int = 0
    replies: int = 0
    bytes_in: int = 0
    bytes_skipped: int = 0
    dropped_s: float = 0.0
    slowest_reply_s: float = 0.0   # longest time from a packet's arrival to its last reply
    faults: list[str] = field(default_factory=list)


class DynamixelEmulator:
    """Servos ``specs`` on a pty at ``baudrate`` moving ``physics`` (module docstring).

    Args:
        specs: The servos on the bus.
        physics: Joints the servos move (default :class:`SimpleJoints` at 0 rad).
        baudrate: Serial speed for the byte timing [bit/s]; the servos' Baud Rate registers
            are set to match.
        faults: Scheduled faults.
        byte_timing: False answers as fast as possible (no wire or return-delay times).
    """

    def __init__(self, specs: Sequence[ServoSpec], physics: JointPhysics | None = None,
                 baudrate: int = 1_000_000, faults: Sequence[Fault] = (),
                 byte_timing: bool = True):
        if baudrate not in BAUD_RATES.values():
            raise InputError(f"expected a Dynamixel baud rate ({sorted(BAUD_RATES.values())}), "
                             f"got {baudrate}", key="baudrate", value=baudrate)
        self.baudrate = baudrate
        self.byte_s = 10.0 / baudrate
        self.byte_timing = byte_timing
        servos = []
        for spec in specs:
            servo = EmulatedServo(table(spec.model), spec.servo_id)
            m = servo.memory
            m.set("baud_rate", {v: k for k, v in BAUD_RATES.items()}[baudrate])
            m.set("secondary_id", spec.secondary_id)
            m.set("drive_mode", int(spec.reverse))
            servos.append(servo)
        n_joints = 1 + max(s.mount.joint for s in specs)
        self.physics = physics or SimpleJoints.at(np.zeros(n_joints))
        self.bus = EmulatedBus(servos)
        self.bank = ServoBank(servos, [s.mount for s in specs], self.physics)
        self.bus.on_write = self._on_write
        self.faults = sorted(faults, key=lambda f: f.at_s)
        self.stats = EmulatorStats()
        self.lock = threading.RLock()
        self._master = self._slave = -1
        self._thread: threading.Thread | None = None
        self._running = False
        self._t0 = 0.0
        self._torque_on_at: float | None = None
        self._late: list[tuple[float, bytes]] = []  # (due [monotonic s], reply)
        self.port = ""
        self.error: BaseException | None = None

    # --- life cycle ----------------------------------------------------------------------------
    def start(self) -> str:
        """Open the pty, start serving; returns the port name to connect to."""
        self._master, self._slave, self.port = open_raw_pty()
        self._running = True
        self._t0 = time.monotonic()
        self._thread = threading.Thread(target=self._serve, name="dynamixel-emulator",
                                        daemon=True)
        self._thread.start()
        return self.port

    @property
    def running(self) -> bool:
        return self._running and self._thread is not None and self._thread.is_alive()

    def stop(self) -> None:
        """Stop serving and close the pty. Idempotent."""
        self._running = False
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        close_quietly(self._master, self._slave)
        self._master = self._slave = -1

    def __enter__(self) -> Self:
        self.start()
        return self

    def __exit__(self, *exc) -> None:
        self.stop()

    def now(self) -> float:
        return time.monotonic() - self._t0

    def servo(self, servo_id: int) -> EmulatedServo:
        for s in self.bus.servos:
            if s.id == servo_id:
                return s
        raise unknown_name("servo id", str(servo_id), [str(s.id) for s in self.bus.servos])

    # --- faults --------------------------------------------------------------------------------
    def inject(self, kind: str, servo_id: int = 1) -> None:
        """Make servo ``servo_id`` show fault ``kind`` now."""
        Fault(kind, servo_id)
        with self.lock:
            self.stats.faults.append(f"{kind}:{servo_id}@{self.now():.3f}")
            if kind == "disconnect":
                self._running = False
                return
            s = self.servo(servo_id)
            if kind == "silent":
                s.silent = True
            elif kind == "crc":
                s.corrupt_crc = True
            elif kind == "late":
                s.late_s = LATE_S
            elif kind == "overload":
                self.bank.hardware_error(s, 5)
            elif kind == "overheat":
                k = self.bus.servos.index(s)
                self.bank.temperature[k] = s.memory.get("temperature_limit") + 5.0
                self.bank.hardware_error(s, 2)
            elif kind == "watchdog":
                self.bank.fire_watchdog(s)

    def _on_write(self, servo: EmulatedServo, names: list[str]) -> None:
        """A host's write: to the servo firmware; the first Torque Enable = 1 starts the
        fault clock."""
        self.bank.on_write(servo, names)
        if self._torque_on_at is None and "torque_enable" in names \
                and servo.memory.get("torque_enable"):
            self._torque_on_at = self.now()

    @property
    def torque_on_at(self) -> float | None:
        """When the host first switched a servo's torque on [s since start], or None."""
        return self._torque_on_at

    def _due_faults(self) -> None:
        if self._torque_on_at is None:
            return
        while self.faults and self.now() - self._torque_on_at >= self.faults[0].at_s:
            fault = self.faults.pop(0)
            self.inject(fault.kind, fault.servo_id)

    # --- serving -------------------------------------------------------------------------------
    def _advance(self) -> None:
        """Physics up to wall time (module docstring)."""
        period = self.physics.period_s
        behind = self.now() - self.bank.time_s - self.stats.dropped_s
        if behind > MAX_CATCH_UP_S:
            self.stats.dropped_s += behind - MAX_CATCH_UP_S
            behind = MAX_CATCH_UP_S
        for k in range(int(behind / period)):
            # catching up: stop for a packet that arrives meanwhile (the rest next time)
            if k and k % 4 == 0 and select.select([self._master], [], [], 0)[0]:
                break
            self.bank.step()
        self.bus.now = self.now()
        self.bank.check_watchdogs(self.now())

    def _serve(self) -> None:
        reader = p.PacketReader()
        try:
            while self._running:
                readable, _, _ = select.select([self._master], [], [], self.physics.period_s)
                with self.lock:
                    while self._late and self._late[0][0] <= time.monotonic():
                        os.write(self._master, self._late.pop(0)[1])
                        self.stats.replies += 1
                    self._due_faults()
                    if not self._running:
                        break
                    if readable:  # answer first: the host is waiting, the physics is not
                        t_arrival = time.monotonic()
                        self.bus.now = self.now()
                        data = os.read(self._master, 4096)
                        self.stats.bytes_in += len(data)
                        for packet in reader.feed(data):
                            self._answer(packet, t_arrival)
                        self.stats.bytes_skipped = reader.skipped
                    self._advance()
        except OSError as e:  # the other end went away
            self.error = e
        except BaseException as e:  # keep the failure for the owner to see
            self.error = e
            raise
        finally:
            self._running = False
            close_quietly(self._master)  # a disconnect: the host sees the port vanish
            self._master = -1

    def _answer(self, packet: p.Packet, t_arrival: float) -> None:
        self.stats.packets += 1
        # Answer from the state as it is (at most one period old): catching the physics up
        # first would make a reply wait for the simulation whenever the host was descheduled.
        self.bank.sync_registers()
        replies = self.bus.handle(packet)
        for s in self.bus.servos:
            if s.pending_reboot:
                s.pending_reboot = False
                self.bank.reboot(s)
        t = t_arrival + len(packet.raw) * self.byte_s
        for servo, reply in replies:
            if servo.late_s:  # sent later, while the bus goes on (on a real bus: a collision)
                self._late.append((time.monotonic() + servo.late_s, reply))
                continue
            if self.byte_timing:
                t += servo.memory.get("return_delay_time") * 2e-6 + len(reply) * self.byte_s
                _sleep_until(t)
            os.write(self._master, reply)
            self.stats.replies += 1
        self.stats.slowest_reply_s = max(self.stats.slowest_reply_s,
                                         time.monotonic() - t_arrival)


def _sleep_until(t: float) -> None:
    """Sleep until monotonic time ``t``, spinning for the last 0.2 ms (sleep is coarse)."""
    while (remaining := t - time.monotonic()) > 0:
        if remaining > 2e-4:
            time.sleep(remaining - 1.5e-4)


def specs_for_profile(backend: dict, joint_count: int, offsets=None, signs=None) -> list[ServoSpec]:
    """The servos of a robot profile's ``[backends.dynamixel]``: one per joint, each shadow
    mounted mirrored on its joint with Drive Mode reverse and its primary as Secondary ID.
    ``offsets``/``signs`` (per joint) mount the primaries off centre or reversed (for
    calibration tests; default 2048 and +1)."""
    from inkarm.hardware.dynamixel.config import DynamixelConfig

    cfg = backend if isinstance(backend, DynamixelConfig) else DynamixelConfig.from_table(
        backend, joint_count)
    offsets = [2048.0] * joint_count if offsets is None else list(offsets)
    signs = [1] * joint_count if signs is None else list(signs)
    specs = []
    for j, (servo_id, model) in enumerate(zip(cfg.ids, cfg.models)):
        specs.append(ServoSpec(servo_id, model, Mount(j, offsets[j], signs[j])))
    for j, shadow_id in cfg.shadows.items():
        specs.append(ServoSpec(shadow_id, cfg.models[j],
                               Mount(j, 4096.0 - offsets[j], -signs[j]),
                               secondary_id=cfg.ids[j], reverse=True))
    return specs


class EmulatorProcess:
    """An emulator in a child process (its own interpreter: the host's busy polling of the
    port and the servos' physics do not share one GIL, as they share nothing on real hardware).

    ``factory()`` builds the :class:`DynamixelEmulator` in the child and ``result(emulator)``
    what :meth:`stop` returns (e.g. the twin's canvas); both must pickle (module-level
    functions or :func:`functools.partial` of them).
    """

    def __init__(self, factory, result=None, start_timeout_s: float = 120.0):
        self.factory, self.result, self.start_timeout_s = factory, result, start_timeout_s
        self.port = ""
        self.stats: EmulatorStats | None = None
        self._proc = None
        self._conn = None

    def start(self) -> str:
        import multiprocessing as mp

        ctx = mp.get_context("spawn")
        self._conn, child = ctx.Pipe()
        self._proc = ctx.Process(target=_serve_child, args=(child, self.factory, self.result),
                                 daemon=True)
        self._proc.start()
        child.close()
        if not self._conn.poll(self.start_timeout_s):
            self._proc.kill()
            raise RuntimeError("the emulator process did not start")
        try:
            kind, value = self._conn.recv()
        except EOFError:
            kind, value = "error", f"exit code {self._proc.exitcode}"
        if kind != "port":
            self._proc.join(5)
            raise RuntimeError(f"the emulator process failed: {value}")
        self.port = value
        return value

    def inject(self, kind: str, servo_id: int = 1) -> None:
        self._conn.send(("inject", kind, servo_id))

    def stop(self):
        """Stop the child; returns ``result(emulator)`` (None if it is gone)."""
        if self._proc is None:
            return None
        value = None
        try:
            self._conn.send(("stop",))
            if self._conn.poll(30.0):
                _, value, self.stats, error = self._conn.recv()
                if error:
                    raise RuntimeError(f"the emulator failed: {error}")
        except (BrokenPipeError, EOFError, OSError):
            pass
        finally:
            self._proc.join(10.0)
            if self._proc.is_alive():
                self._proc.kill()
            self._proc = None
        return value

    def __enter__(self) -> Self:
        self.start()
        return self

    def __exit__(self, *exc) -> None:
        self.stop()


def _serve_child(conn, factory, result) -> None:
    try:
        emulator = factory()
        port = emulator.start()
    except Exception as e:  # report, then exit  # noqa: BLE001
        conn.send(("error", f"{type(e).__name__}: {e}"))
        return
    conn.send(("port", port))
    try:
        while True:
            if not conn.poll(0.2):
                continue
            message = conn.recv()
            if message[0] == "inject":
                emulator.inject(message[1], message[2])
            elif message[0] == "stop":
                break
    except (EOFError, OSError):
        pass
    finally:
        emulator.stop()
    error = "" if emulator.error is None or isinstance(emulator.error, OSError) \
        else repr(emulator.error)
    try:
        conn.send(("result", result(emulator) if result else None, emulator.stats, error))
    except (BrokenPipeError, OSError):
        pass


def simple_emulator(specs, q0, faults=(), baudrate=1_000_000, inertia=0.02, damping=0.5,
                    byte_timing=True) -> DynamixelEmulator:
    """An emulator of ``specs`` on :class:`SimpleJoints` starting at ``q0`` (picklable, for
    :class:`EmulatorProcess`)."""
    return DynamixelEmulator(specs, SimpleJoints.at(q0, inertia=inertia, damping=damping),
                             baudrate=baudrate, faults=faults, byte_timing=byte_timing)
