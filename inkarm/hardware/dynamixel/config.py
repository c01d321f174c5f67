"""A robot profile's ``[backends.dynamixel]`` table, checked, as :class:`DynamixelConfig`.

::

    [backends.dynamixel]
    ids = [1, 2, 4, 6, 7, 8]                 # servo id per joint
    shadows = { shoulder = 3, elbow = 5 }    # a joint's second servo (Secondary ID = primary)
    models = ["XM430-W350", ...]             # per joint (inkarm.hardware.dynamixel.tables)
    baudrate = 1000000                       # [bit/s]
    operating_mode = "extended_position"     # or "position", "current_based_position",
                                             # "current" (torque commands; the host's PID)
    position_p = [...]                       # register values per joint (or one number):
    position_i = [...]                       #   P/I/D, feedforward_1st/2nd,
    position_d = [...]                       #   profile_velocity, profile_acceleration
    return_delay_us = 0                      # Return Delay Time written at start [us]
    status_return_level = 2                  # Status Return Level (68) written at start: 2
                                             #   (every instruction answered) or 1 (only
                                             #   PING and reads); absent: as the servos are
    watchdog_ms = 100                        # Bus Watchdog dead-man [ms] (0: off)
    max_step_deg = 3.0                       # largest goal change per control period [deg]
    limit_margin_deg = 2.0                   # software limits inside the joint ranges [deg]
    pen_lift_deg = [0, -6, 4, 0, 0, 0]       # joint move that lifts the pen [deg]
    park_deg = [...]                         # a rest pose where close() parks and lets go
                                             #   (default: home, where it holds: released
                                             #   over the sheet the arm falls on it)
    on_fault = "hold"                        # after pen up: "hold" or "torque_off"
    on_close = "park"                        # "park" (then torque off at park_deg, holding
                                             #   at home), "hold", "torque_off"
    retries = 2                              # extra tries of a failed bus transaction
    latency_ms = 16                          # USB latency timer in the reply timeout [ms]

Every bad value is an :class:`inkarm.errors.InputError` naming ``backends.dynamixel.<key>``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from inkarm.errors import InkarmError, InputError
from inkarm.hardware.dynamixel.tables import BAUD_RATES, OPERATING_MODES, table
from inkarm.io.toml import TomlReader

GAIN_KEYS = ("position_p", "position_i", "position_d", "feedforward_1st", "feedforward_2nd",
             "profile_velocity", "profile_acceleration")
KEYS = ("ids", "shadows", "models", "baudrate", "operating_mode", *GAIN_KEYS, "return_delay_us",
        "status_return_level", "watchdog_ms", "max_step_deg", "limit_margin_deg",
        "pen_lift_deg", "park_deg", "on_fault", "on_close", "retries", "latency_ms")
GAIN_MAX = {"profile_velocity": 32767, "profile_acceleration": 32767}


@dataclass(frozen=True)
class DynamixelConfig:
    """The Dynamixel backend of one robot (module docstring); per-joint arrays are (n,)."""

    ids: tuple[int, ...]
    models: tuple[str, ...]
    shadows: Mapping[int, int] = field(default_factory=dict)   # joint index -> shadow id
    baudrate: int = 1_000_000
    operating_mode: str = "extended_position"
    gains: Mapping[str, np.ndarray] = field(default_factory=dict)
    return_delay_us: int = 0
    status_return_level: int | None = None
    watchdog_ms: int = 100
    max_step_deg: float = 3.0
    limit_margin_deg: float = 2.0
    pen_lift_deg: np.ndarray | None = None
    park_deg: np.ndarray | None = None
    on_fault: str = "hold"
    on_close: str = "park"
    retries: int = 2
    latency_ms: float = 16.0

    @property
    def n(self) -> int:
        return len(self.ids)

    @property
    def all_ids(self) -> tuple[int, ...]:
        """Every servo on the bus: the joints' then the shadows'."""
        return (*self.ids, *self.shadows.values())

    @property
    def servos_per_joint(self) -> np.ndarray:
        """How many servos drive each joint, (n,): 2 where a shadow doubles it."""
        return np.array([2.0 if j in self.shadows else 1.0 for j in range(self.n)])

    @classmethod
    def from_table(cls, data: Mapping, joint_count: int, joint_names=(), source: str = "",
                   ) -> DynamixelConfig:
        """Check and convert a ``[backends.dynamixel]`` table for ``joint_count`` joints."""
        rd = TomlReader(source)
        base = "backends.dynamixel"
        data = rd.table(dict(data), base)
        rd.keys(data, KEYS, base)
        n = joint_count
        names = tuple(joint_names) or tuple(str(i) for i in range(n))

        def key(k):
            return f"{base}.{k}"

        def per_joint(k, value, low, high, integer=True):
            values = value if isinstance(value, list) else [value] * n
            if len(values) != n:
                raise rd.error(key(k), f"expected {n} values (one per joint), got {len(values)}",
                               value=value)
            check = rd.integer if integer else rd.number
            out = [check(v, f"{key(k)}[{i}]", low, high) if integer else
                   check(v, f"{key(k)}[{i}]", low, maximum=high) for i, v in enumerate(values)]
            return np.array(out, dtype=float)

        if "ids" not in data or "models" not in data:
            raise rd.error(base, "expected ids and models (one per joint)")
        ids = tuple(int(v) for v in per_joint("ids", data["ids"], 0, 252))
        models = data["models"]
        if not isinstance(models, list) or len(models) != n:
            raise rd.error(key("models"), f"expected {n} model names (one per joint)",
                           value=models)
        for i, m in enumerate(models):
            try:
                table(rd.text(m, f"{key('models')}[{i}]"))
            except InkarmError as e:
                raise e.within(file=source or None, key=f"{key('models')}[{i}]") from None
        shadows = {}
        for joint, sid in rd.table(data.get("shadows", {}), key("shadows")).items():
            if joint not in names:
                raise rd.error(f"{key('shadows')}.{joint}", "unknown joint; expected one of "
                               f"{', '.join(names)}", value=joint, choices=names)
            shadows[names.index(joint)] = rd.integer(sid, f"{key('shadows')}.{joint}", 0, 252)
        every = [*ids, *shadows.values()]
        if len(set(every)) != len(every):
            raise rd.error(key("ids"), f"servo ids must differ, got {every}", value=every)
        baud = rd.integer(data.get("baudrate", 1_000_000), key("baudrate"), 9600)
        if baud not in BAUD_RATES.values():
            raise rd.error(key("baudrate"), f"expected one of {sorted(BAUD_RATES.values())}, got "
                           f"{baud}", value=baud)
        gains = {k: per_joint(k, data[k], 0, GAIN_MAX.get(k, 16383))
                 for k in GAIN_KEYS if k in data}
        lift = data.get("pen_lift_deg")
        park = data.get("park_deg")
        mode = rd.choice(data.get("operating_mode", "extended_position"), key("operating_mode"),
                         ("position", "extended_position", "current_based_position", "current"))
        if mode == "current":
            blind = [m for m in models if "current_limit" not in table(m)]
            if blind:
                raise rd.error(key("operating_mode"), f"current mode needs servos that sense "
                               f"current; {', '.join(sorted(set(blind)))} do not", value=mode)
            if data.get("on_fault", "torque_off") != "torque_off" or \
                    data.get("on_close", "torque_off") != "torque_off":
                raise rd.error(key("operating_mode"), "a servo in current mode cannot lift the "
                               "pen or hold by itself: set on_fault and on_close to "
                               "\"torque_off\"", value=mode)
        for i, m in enumerate(models):
            if OPERATING_MODES[mode] not in table(m)["operating_mode"].values:
                raise rd.error(key("operating_mode"), f"a {m} (models[{i}]) has no {mode} mode "
                               "(its Operating Mode (11) would refuse it)", value=mode)
        return cls(
            ids=ids, models=tuple(models), shadows=shadows, baudrate=baud,
            operating_mode=mode,
            gains=gains,
            return_delay_us=int(rd.integer(data.get("return_delay_us", 0),
                                           key("return_delay_us"), 0, 508)),
            status_return_level=None if "status_return_level" not in data else int(
                rd.integer(data["status_return_level"], key("status_return_level"), 1, 2)),
            watchdog_ms=int(rd.integer(data.get("watchdog_ms", 100), key("watchdog_ms"), 0, 2540)),
            max_step_deg=rd.number(data.get("max_step_deg", 3.0), key("max_step_deg"), 0.0,
                                   strict=True, maximum=180.0),
            limit_margin_deg=rd.number(data.get("limit_margin_deg", 2.0),
                                       key("limit_margin_deg"), 0.0, maximum=45.0),
            pen_lift_deg=None if lift is None else per_joint("pen_lift_deg", lift, -30.0, 30.0,
                                                             integer=False),
            park_deg=None if park is None else per_joint("park_deg", park, -360.0, 360.0,
                                                         integer=False),
            on_fault=rd.choice(data.get("on_fault", "hold"), key("on_fault"),
                               ("hold", "torque_off")),
            on_close=rd.choice(data.get("on_close", "park"), key("on_close"),
                               ("park", "hold", "torque_off")),
            retries=int(rd.integer(data.get("retries", 2), key("retries"), 0, 10)),
            latency_ms=rd.number(data.get("latency_ms", 16), key("latency_ms"), 0.0,
                                 maximum=1000.0),
        )

    @classmethod
    def of(cls, profile) -> DynamixelConfig:
        """The config of a :class:`inkarm.robots.profile.RobotProfile`."""
        if "dynamixel" not in profile.backends:
            raise InputError(f"robot {profile.name!r} has no [backends.dynamixel] table (servo "
                              "ids and models)", file=profile.source or None,
                              key="backends.dynamixel")
        return cls.from_table(profile.backends["dynamixel"], profile.n, profile.joint_names,
                              profile.source)

    @property
    def mode_number(self) -> int:
        return OPERATING_MODES[self.operating_mode]


def with_dynamixel(profile, **changes):
    """``profile`` with keys of its ``[backends.dynamixel]`` table replaced by ``changes``."""
    backends = dict(profile.backends)
    backends["dynamixel"] = {**backends["dynamixel"], **changes}
    return replace(profile, backends=backends)
