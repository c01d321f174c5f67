"""The tables of a scenario file and how each is read: the job's ``[controller]`` (the law,
its settings, added watchdogs), the simulator's ``[sim]`` and ``[sim.plant]`` (with the 0.2
names ``[cell]`` and ``[plant]``), the devices' ``[dynamixel]`` and ``[plotter]``, and the
rules every table of dataclass fields follows (:func:`dataclass_table`). Each error names the
file, the dotted key, the value and the closest valid key; :mod:`inkarm.jobs.scenario` puts the
tables together."""

from __future__ import annotations

import dataclasses
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from inkarm.control.config import LoopConfig
from inkarm.control.laws import DEFAULT_LAW, LawSpec, make_law
from inkarm.control.watchdogs import WatchdogSpec, make_watchdog
from inkarm.core.equality import same
from inkarm.errors import InkarmError, ScenarioError
from inkarm.io.toml import TomlReader
from inkarm.robots.profile import RobotProfile
from inkarm.sim.cell_config import CellConfig
from inkarm.sim.imperfections import PlantTruth

PLOTTER_KEYS = ("profile", "page_origin", "homing")
AXIDRAW_KEYS = ("profile", "page_origin")
# The simulator's tables of 0.2, kept for one release: [cell] is now [sim], [plant] [sim.plant].
OLD_SIM_TABLES = {"cell": "sim", "plant": "sim.plant"}


def table_of(obj) -> dict:
    """A dataclass as a TOML table: the fields that differ from their defaults, tuples as
    lists."""
    if obj is None:
        return {}
    out = {}
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if value is None or (f.default is not dataclasses.MISSING and same(value, f.default)):
            continue
        out[f.name] = list(value) if isinstance(value, tuple | np.ndarray) else value
    return out


def plant_table(truth: PlantTruth) -> dict:
    table = table_of(dataclasses.replace(truth, random={}))
    table.pop("random", None)
    if truth.random:
        table["random"] = {k: list(v) for k, v in truth.random.items()}
    return table


def read_plant(rd: TomlReader, raw, key: str = "sim.plant", base_dir: Path | None = None
               ) -> PlantTruth:
    """The ``[sim.plant]`` table: :class:`PlantTruth` fields, and ``[sim.plant.random]``
    ranges; ``relief_file`` is resolved against ``base_dir`` (the scenario's folder)."""
    table = dict(rd.table(raw, key))
    if "relief_file" in table:
        name = Path(rd.text(table["relief_file"], f"{key}.relief_file"))
        table["relief_file"] = str(name if base_dir is None else base_dir / name)
    random = rd.table(table.pop("random", {}), f"{key}.random")
    ranges = {}
    for name, bounds in random.items():
        pair = rd.array(bounds, f"{key}.random.{name}", 1)
        if len(pair) != 2:
            raise rd.error(f"{key}.random.{name}", f"expected [low, high], got {bounds!r}",
                           value=bounds)
        ranges[name] = (float(pair[0]), float(pair[1]))
    truth = dataclass_table(rd, table, key, PlantTruth)
    if not ranges:
        return truth
    try:
        return dataclasses.replace(truth, random=ranges)
    except InkarmError as e:
        raise ScenarioError(e.message, key=e.key, value=e.value,
                            choices=e.choices).within(file=rd.source, key=key) from None


def read_sim(rd: TomlReader, data: dict, warn: bool, base_dir: Path | None = None
             ) -> dict[str, Any]:
    """The ``[sim]`` table: the simulated cell (:class:`CellConfig` fields) and, in
    ``[sim.plant]``, the plant's truth. The 0.2 tables ``[cell]`` and ``[plant]`` are read as
    these (with a warning when ``warn``: a file; overrides may use either spelling). Returns the
    Scenario fields ``cell`` and ``plant``."""
    sim = dict(rd.table(data.get("sim", {}), "sim"))
    rd.keys(sim, (*(f.name for f in dataclasses.fields(CellConfig)), "plant"), "sim")
    plant, plant_key = sim.pop("plant", None), "sim.plant"
    cell, cell_key = sim, "sim"
    for old, new in OLD_SIM_TABLES.items():
        if old not in data:
            continue
        if (old == "cell" and sim) or (old == "plant" and plant is not None):
            raise rd.error(old, f"give [{new}] only ([{old}] is its old name)")
        if warn:
            warnings.warn(f"{rd.source}: the table [{old}] is deprecated and goes in the next "
                          f"release; write [{new}]", UserWarning, stacklevel=3)
        if old == "cell":
            cell, cell_key = rd.table(data["cell"], "cell"), "cell"
        else:
            plant, plant_key = data["plant"], "plant"
    return {"cell": dataclass_table(rd, cell, cell_key, CellConfig),
            "plant": read_plant(rd, plant if plant is not None else {}, plant_key, base_dir)}


def read_dynamixel(rd: TomlReader, robot: RobotProfile, table: dict,
                    base_dir: Path) -> RobotProfile:
    """``robot`` with the ``[dynamixel]`` table's keys replacing those of its
    ``[backends.dynamixel]`` (``calibration`` aside: the backend's file), checked as the
    profile's own table is; errors name ``dynamixel.<key>``."""
    from inkarm.hardware.dynamixel.config import KEYS, DynamixelConfig, with_dynamixel

    rd.keys(table, (*KEYS, "calibration"), "dynamixel")
    changes = {k: v for k, v in table.items() if k != "calibration"}
    if "calibration" in table:
        file = base_dir / rd.text(table["calibration"], "dynamixel.calibration")
        if not file.is_file():
            raise rd.error("dynamixel.calibration", f"no such file: {file}",
                           value=table["calibration"])
    if not changes:
        return robot
    if "dynamixel" not in robot.backends:
        raise rd.error("dynamixel", f"robot {robot.name!r} has no [backends.dynamixel] table to "
                       "change (servo ids and models)")
    changed = with_dynamixel(robot, **changes)
    try:
        DynamixelConfig.of(changed)
    except InkarmError as e:
        key = (e.key or "").removeprefix("backends.dynamixel")
        raise ScenarioError(e.message, key=f"dynamixel{key}", value=e.value,
                            choices=e.choices, file=rd.source) from None
    return changed


def read_backend_tables(rd: TomlReader, data: dict, robot: RobotProfile,
                    base_dir: Path) -> dict[str, Any]:
    """The Scenario fields of the ``[dynamixel]``, ``[plotter]`` and ``[axidraw]`` tables (how
    the job reaches each device; ``[dynamixel]`` has been applied to the robot profile
    already)."""
    dynamixel = rd.table(data.get("dynamixel", {}), "dynamixel")
    plotter = rd.table(data.get("plotter", {}), "plotter")
    rd.keys(plotter, PLOTTER_KEYS, "plotter")
    profile = None
    if "profile" in plotter:
        from inkarm.hardware.plotter.profiles import load_profile

        profile = device_profile(rd, plotter["profile"], "plotter.profile", load_profile,
                                 base_dir)
    placement: tuple[tuple[str, Any], ...] = ()
    if "page_origin" in plotter or "homing" in plotter:
        from inkarm.hardware.plotter.profiles import parse_placement

        parse_placement(rd, plotter, "plotter.")  # refused here, naming plotter.<key>
        placement = tuple((k, frozen(plotter[k])) for k in ("page_origin", "homing")
                          if k in plotter)
    calibration = dynamixel.get("calibration")
    pairs = tuple((k, frozen(v)) for k, v in dynamixel.items() if k != "calibration")
    if calibration is not None:
        pairs += (("calibration", str((base_dir / calibration).resolve())),)
    return {"dynamixel": pairs, "plotter_profile": profile, "plotter_placement": placement,
            "axidraw": read_axidraw(rd, data, base_dir)}


def read_calibration_key(rd: TomlReader, data: dict, base_dir: Path) -> str | None:
    """The top-level ``calibration``: None (none given), ``"auto"`` (the robot's file in the
    user's configuration folder, when there is one: :func:`inkarm.jobs.calibration.
    scenario_calibration`), or a calibration file resolved beside the scenario, read and
    checked here so that its errors name the scenario's key."""
    if "calibration" not in data:
        return None
    name = rd.text(data["calibration"], "calibration")
    if name == "auto":
        return name
    from inkarm.robots.calibration import read_calibration

    path = (base_dir / Path(name).expanduser()).resolve()
    if not path.is_file():
        raise rd.error("calibration", f'no such calibration file: {path} (expected a file '
                       f'written by `inkarm calibrate`, or "auto")', value=name)
    try:
        read_calibration(path)
    except InkarmError as e:
        raise ScenarioError(f"{e} (the calibration file it names)", file=rd.source,
                            key="calibration", value=name) from None
    return str(path)


def device_profile(rd: TomlReader, raw, key: str, load, base_dir: Path) -> str:
    """A device profile's name, or its file resolved beside the scenario, checked by ``load``
    (errors name the scenario file and ``key``)."""
    name = rd.text(raw, key)
    if name.endswith(".toml"):
        name = str((base_dir / name).resolve())
    try:
        load(name)
    except InkarmError as e:
        raise ScenarioError(e.message, key=key, value=e.value, choices=e.choices,
                            file=rd.source) from None
    return name


def read_axidraw(rd: TomlReader, data: dict, base_dir: Path) -> tuple[tuple[str, Any], ...]:
    """The ``[axidraw]`` table: ``profile`` (a name or a file, checked by loading it) and
    ``page_origin`` (the sheet's upper-left corner in machine [mm], two numbers)."""
    table = rd.table(data.get("axidraw", {}), "axidraw")
    rd.keys(table, AXIDRAW_KEYS, "axidraw")
    pairs: list[tuple[str, Any]] = []
    if "profile" in table:
        from inkarm.hardware.axidraw.profiles import load_profile as load_axidraw

        pairs.append(("profile", device_profile(rd, table["profile"], "axidraw.profile",
                                                load_axidraw, base_dir)))
    if "page_origin" in table:
        pairs.append(("page_origin", rd.pair(table["page_origin"], "axidraw.page_origin",
                                             -10000, 10000, "[x, y] in mm (each within +-10000)")))
    return tuple(pairs)


# The `[controller] command` of 0.2, kept for one release: the law that does what it did.
COMMAND_LAWS = {"position": "position", "torque": "joint_pid"}


def read_controller(rd: TomlReader, raw) -> dict[str, Any]:
    """The ``[controller]`` table: :class:`LoopConfig` fields, ``law`` and its settings table
    ``[controller.<law>]``, ``watchdogs`` and theirs (:mod:`inkarm.control.laws`,
    :mod:`inkarm.control.watchdogs`). Returns the Scenario fields ``controller``, ``law`` and
    ``watchdogs``; the law and every watchdog are built once here, so that a bad setting is
    refused before anything runs."""
    table = dict(rd.table(raw, "controller"))
    if "command" in table:
        command = rd.choice(table.pop("command"), "controller.command", tuple(COMMAND_LAWS))
        if "law" in table:
            raise rd.error("controller.command", "give law only (command is its old name)",
                           value=command)
        table["law"] = COMMAND_LAWS[command]
        warnings.warn(f"{rd.source}: controller.command = {command!r} is deprecated and goes "
                      f"in the next release; write controller.law = {table['law']!r}",
                      UserWarning, stacklevel=2)
    law_name = rd.text(table.pop("law", DEFAULT_LAW), "controller.law")
    names = table.pop("watchdogs", [])
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
        raise rd.error("controller.watchdogs", f"expected a list of watchdog names, got "
                       f"{names!r}", value=names)
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise rd.error("controller.watchdogs", f"each watchdog once: {', '.join(twice)} is "
                       f"listed more than once", value=names)
    settings = {}
    for name in dict.fromkeys((law_name, *names)):  # (a law and a watchdog may share a name)
        section = table.pop(name, {})
        settings[name] = tuple((k, frozen(v)) for k, v in
                               rd.table(section, f"controller.{name}").items())
    for name, value in table.items():
        if isinstance(value, dict):  # the settings of a law or watchdog not in use
            raise rd.error(f"controller.{name}", f"settings of {name!r}, which this scenario "
                           f"does not use (law = {law_name!r}, watchdogs = {names}); name it, "
                           f"or remove the table", value=name)
    try:
        law = LawSpec(law_name, settings[law_name])
        make_law(law.name, dict(law.settings))
        watchdogs = tuple(WatchdogSpec(n, settings[n]) for n in names)
        for spec in watchdogs:
            make_watchdog(spec.name, dict(spec.settings))
    except InkarmError as e:
        raise e.within(file=rd.source) from None
    return {"controller": dataclass_table(rd, table, "controller", LoopConfig), "law": law,
            "watchdogs": watchdogs}


def frozen(value):
    """A TOML value with its arrays as tuples (a law's settings are part of a hashable spec)."""
    if isinstance(value, list):
        return tuple(frozen(v) for v in value)
    if isinstance(value, dict):
        return {k: frozen(v) for k, v in value.items()}
    return value


def controller_table(controller: LoopConfig, law: LawSpec,
                      watchdogs: tuple[WatchdogSpec, ...]) -> dict:
    """The ``[controller]`` table that parses back to ``controller``, ``law`` and
    ``watchdogs``."""
    table = table_of(controller)
    if law.name != DEFAULT_LAW or law.settings:
        table["law"] = law.name
    if watchdogs:
        table["watchdogs"] = [w.name for w in watchdogs]
    for spec in (law, *watchdogs):
        if spec.settings:
            table[spec.name] = {k: thawed(v) for k, v in spec.settings}
    return table


def thawed(value):
    return [thawed(v) for v in value] if isinstance(value, tuple) else value


def dataclass_table(rd: TomlReader, table: dict, key: str, cls):
    """An instance of dataclass ``cls`` from ``table``, each value checked as its field's
    default suggests (numbers, booleans, strings, arrays of numbers); the class's own checks
    name ``key`` and the field."""
    fields = {f.name: f for f in dataclasses.fields(cls)}
    rd.keys(table, tuple(fields), key)
    out = {}
    for name, value in table.items():
        where = f"{key}.{name}"
        default = fields[name].default
        if default is dataclasses.MISSING and fields[name].default_factory is not dataclasses.MISSING:
            default = fields[name].default_factory()
        if isinstance(default, bool):
            out[name] = rd.boolean(value, where)
        elif isinstance(default, str) or name.endswith("_file"):
            out[name] = rd.text(value, where)
        elif isinstance(default, tuple | list | np.ndarray):
            arr = rd.array(value, where, 1)
            if len(arr) != len(default):
                raise rd.error(where, f"expected {len(default)} numbers, got {len(arr)}",
                               value=value)
            out[name] = tuple(float(v) for v in arr)
        elif isinstance(value, list):
            out[name] = tuple(float(v) for v in rd.array(value, where, 1))
        else:
            out[name] = rd.number(value, where)
    try:
        return cls(**out)
    except InkarmError as e:
        if e.key is None or e.key.split(".")[0] not in fields:
            e.key = None
        raise ScenarioError(e.message, key=e.key, value=e.value,
                            choices=e.choices).within(file=rd.source, key=key) from None


__all__ = ["AXIDRAW_KEYS", "COMMAND_LAWS", "OLD_SIM_TABLES", "PLOTTER_KEYS", "controller_table",
           "dataclass_table", "frozen", "plant_table", "read_backend_tables", "read_controller",
           "read_dynamixel", "read_plant", "read_sim", "table_of", "thawed"]
