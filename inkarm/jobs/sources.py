"""Scenario sources: what to draw. One class per kind, registered in :data:`SOURCES`.

A source class is a frozen dataclass whose fields are its TOML keys (besides ``kind``), with
``parse(rd, table, base_dir)`` to check a ``[source]`` table and ``drawing(seed)`` to build the
drawing in its own coordinates [mm] and times [s]. Adding a source is one class and one entry.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError
from inkarm.io.toml import TomlReader


def _file(rd: TomlReader, table: dict, base_dir: Path) -> Path:
    if "file" not in table:
        raise rd.error("source.file", "required")
    file = base_dir / rd.text(table["file"], "source.file")
    if not file.is_file():
        raise rd.error("source.file", f"no such file: {file}", value=table["file"])
    return file.resolve()  # absolute: a scenario's overrides re-parse it from another base


@dataclass(frozen=True)
class PlanSource:
    """A motor plan (the plan-file schema), from ``file`` or inline as ``plan``; its mean, or
    the stochastic ``sample`` (0-based indices) copies spaced ``spacing_mm`` along x."""

    file: Path | None = None
    plan: dict | None = None
    sample: tuple[int, ...] = ()
    spacing_mm: float = 0.0
    kind: ClassVar[str] = "plan"

    @classmethod
    def parse(cls, rd: TomlReader, table: dict, base_dir: Path) -> PlanSource:
        if ("file" in table) == ("plan" in table):
            raise rd.error("source", "give one of file (a plan file) and plan (an inline plan)")
        kw: dict[str, Any] = {}
        if "file" in table:
            kw["file"] = _file(rd, table, base_dir)
        else:
            kw["plan"] = rd.table(table["plan"], "source.plan")
        if "sample" in table:
            raw = table["sample"]
            many = isinstance(raw, list)
            if many and not raw:
                raise rd.error("source.sample", "expected a sample index or a non-empty list of "
                               "them")
            kw["sample"] = tuple(rd.integer(v, f"source.sample[{i}]" if many else "source.sample",
                                            0) for i, v in enumerate(raw if many else [raw]))
        if "spacing_mm" in table:
            if len(kw.get("sample", ())) < 2:
                raise rd.error("source.spacing_mm", "only with a list of several samples")
            kw["spacing_mm"] = rd.number(table["spacing_mm"], "source.spacing_mm", 0.0)
        return cls(**kw)

    def drawing(self, seed: int, where: str) -> Drawing:
        from inkarm.io.planfile import load_plan, parse_plan
        from inkarm.plans.realise import realise_plan

        if self.file is not None:
            plan = load_plan(self.file, seed=seed)
        else:
            plan = parse_plan(self.plan, source=f"{where}: source.plan", seed=seed)
        if not self.sample:
            return realise_plan(plan, samples=0).drawing
        result = realise_plan(plan, samples=max(self.sample) + 1)
        strokes = []
        for copy, k in enumerate(self.sample):
            shift = np.zeros(plan.dim)
            shift[0] = copy * self.spacing_mm
            strokes += [Trajectory(t=r.mean.t, pos=r.samples[k] + shift) for r in result.strokes]
        return Drawing(strokes).sequential(pause=plan.pause)


@dataclass(frozen=True)
class TrajectorySource:
    """A recorded or computed pen path: CSV ``t,x,y[,stroke]`` [s, mm]."""

    file: Path
    kind: ClassVar[str] = "trajectory"

    @classmethod
    def parse(cls, rd: TomlReader, table: dict, base_dir: Path) -> TrajectorySource:
        return cls(file=_file(rd, table, base_dir))

    def drawing(self, seed: int, where: str) -> Drawing:
        return Drawing.from_csv(self.file)


@dataclass(frozen=True)
class TextSource:
    """Handwriting from a Hershey script font in a handstyle (:mod:`inkarm.plans.text`)."""

    text: str
    style: str = "faithful"
    height_mm: float | None = None
    kind: ClassVar[str] = "text"

    @classmethod
    def parse(cls, rd: TomlReader, table: dict, base_dir: Path) -> TextSource:
        from inkarm.plans.handstyles import PRESETS

        if "text" not in table:
            raise rd.error("source.text", "required")
        text = rd.text(table["text"], "source.text")
        if not text.strip():
            raise rd.error("source.text", "empty text", value=text)
        kw: dict[str, Any] = {"text": text}
        if "style" in table:
            kw["style"] = rd.choice(table["style"], "source.style", tuple(PRESETS))
        if "height_mm" in table:
            kw["height_mm"] = rd.number(table["height_mm"], "source.height_mm", 0.0, strict=True)
        return cls(**kw)

    def drawing(self, seed: int, where: str) -> Drawing:
        from inkarm.plans.text import write_text

        kwargs = {"height": self.height_mm} if self.height_mm is not None else {}
        return write_text(self.text, self.style, seed=seed, **kwargs).drawing


@dataclass(frozen=True)
class TagSource:
    """An asemic tag evolved by the genetic algorithm (:mod:`inkarm.plans.glyphs`)."""

    style: str = "graffiti"
    kind: ClassVar[str] = "tag"

    @classmethod
    def parse(cls, rd: TomlReader, table: dict, base_dir: Path) -> TagSource:
        from inkarm.plans.handstyles import PRESETS

        if "style" in table:
            return cls(style=rd.choice(table["style"], "source.style", tuple(PRESETS)))
        return cls()

    def drawing(self, seed: int, where: str) -> Drawing:
        from inkarm.plans.glyphs import make_tag

        return make_tag(self.style, seed=seed).realise()


@dataclass(frozen=True)
class TraceSource:
    """A traced path (CSV or SVG), restyled through DPPLA targets (:mod:`inkarm.plans.restyle`)."""

    file: Path
    style: str | None = None
    compression: float | None = None
    kind: ClassVar[str] = "trace"

    @classmethod
    def parse(cls, rd: TomlReader, table: dict, base_dir: Path) -> TraceSource:
        from inkarm.plans.restyle import STYLES

        kw: dict[str, Any] = {"file": _file(rd, table, base_dir)}
        if "style" in table:
            kw["style"] = rd.choice(table["style"], "source.style", STYLES)
        if "compression" in table:
            rho = rd.number(table["compression"], "source.compression")
            if not 0.0 < rho < 1.0:
                raise rd.error("source.compression", f"expected a number in (0, 1), got {rho}",
                               value=rho)
            kw["compression"] = rho
        return cls(**kw)

    def drawing(self, seed: int, where: str) -> Drawing:
        from inkarm.io.trace import load_trace
        from inkarm.plans.restyle import RestyleConfig, restyle

        options = {k: v for k, v in (("compression", self.compression), ("style", self.style))
                   if v is not None}
        return restyle(load_trace(self.file), RestyleConfig(**options)).drawing


@dataclass(frozen=True)
class PrimitivesSource:
    """A scribble of the motor-primitive fHMM (seed 004 Fig. 8, :mod:`inkarm.models.primitives`):
    the ``model`` file (.npz from ``inkarm primitives learn``; default the shipped model of the
    letter a) run generatively for ``duration_s`` [s] from the scenario's seed, one stroke."""

    model: Path | None = None
    duration_s: float = 4.0
    kind: ClassVar[str] = "primitives"

    @classmethod
    def parse(cls, rd: TomlReader, table: dict, base_dir: Path) -> PrimitivesSource:
        kw: dict[str, Any] = {}
        if "model" in table:
            file = base_dir / rd.text(table["model"], "source.model")
            if not file.is_file():
                raise rd.error("source.model", f"no such file: {file}", value=table["model"])
            kw["model"] = file.resolve()
        if "duration_s" in table:
            kw["duration_s"] = rd.number(table["duration_s"], "source.duration_s", 0.0,
                                         strict=True, maximum=600.0)
        return cls(**kw)

    def drawing(self, seed: int, where: str) -> Drawing:
        from inkarm.models.primitives import PrimitiveModel
        from inkarm.models.primitives.generate import SHIPPED_MODEL, scribble

        try:
            model = PrimitiveModel.load(self.model or SHIPPED_MODEL)
        except InputError as e:
            raise e.within(key="model") from None  # source_drawing adds "source."
        return Drawing([scribble(model, self.duration_s, seed=seed)[0]])


@dataclass(frozen=True)
class HumanSource:
    """A human recording (:mod:`inkarm.io.human`): one LASA demonstration (``recording =
    "lasa:SHAPE:DEMO"``) or a pen-tablet CSV or timed SVG (``file``, with its ``time_unit`` "s" or "ms" and
    ``scale_mm`` [mm per unit]), drawn as the hand drew it, or restyled by the handstyle ``hand``
    (``"human"``: the LQT between key-points at the hand's speed minima and peaks,
    :mod:`inkarm.plans.pulses`)."""

    recording: str | None = None
    file: Path | None = None
    time_unit: str = "s"
    scale_mm: float = 1.0
    hand: str | None = None
    kind: ClassVar[str] = "human"

    @classmethod
    def parse(cls, rd: TomlReader, table: dict, base_dir: Path) -> HumanSource:
        from inkarm.io.human import LASA_PREFIX, TIME_UNITS
        from inkarm.plans.handstyles import FITTED, PRESETS

        if ("recording" in table) == ("file" in table):
            raise rd.error("source", "give one of recording (lasa:SHAPE:DEMO) and file (a "
                           "tablet CSV or an SVG with the time of every point)")
        kw: dict[str, Any] = {}
        if "recording" in table:
            name = rd.text(table["recording"], "source.recording")
            if not name.startswith(LASA_PREFIX) or name.count(":") != 2 or "-" in name:
                raise rd.error("source.recording", f"expected one demonstration, "
                               f"{LASA_PREFIX}SHAPE:DEMO, got {name!r}", value=name)
            kw["recording"] = name
        else:
            kw["file"] = _file(rd, table, base_dir)
        if "time_unit" in table:
            kw["time_unit"] = rd.choice(table["time_unit"], "source.time_unit", tuple(TIME_UNITS))
        if "scale_mm" in table:
            kw["scale_mm"] = rd.number(table["scale_mm"], "source.scale_mm", 0.0, strict=True)
        if "hand" in table:
            kw["hand"] = rd.choice(table["hand"], "source.hand", (*PRESETS, *FITTED))
        return cls(**kw)

    def drawing(self, seed: int, where: str) -> Drawing:
        from inkarm.io.human import read_lasa_trace, read_tablet_csv

        if self.recording is not None:
            [drawing] = read_lasa_trace(self.recording)
        elif self.file.suffix.lower() == ".svg":
            from inkarm.io.svgtiming import no_times_error, read_timed_svg, svg_has_times

            if not svg_has_times(self.file):
                raise no_times_error(self.file)
            drawing = read_timed_svg(self.file, self.time_unit)
        else:
            drawing = read_tablet_csv(self.file, self.time_unit, self.scale_mm)
        if self.hand is None:
            return drawing
        from inkarm.plans.handstyles import get_handstyle
        from inkarm.plans.restyle import RestyleConfig, restyle

        cfg = RestyleConfig.from_handstyle(get_handstyle(self.hand), seed=seed)
        return restyle(drawing, cfg).drawing


Source = (PlanSource | TrajectorySource | TextSource | TagSource | TraceSource | PrimitivesSource
          | HumanSource)
SOURCES: dict[str, type] = {
    cls.kind: cls for cls in (PlanSource, TrajectorySource, TextSource, TagSource, TraceSource,
                              PrimitivesSource, HumanSource)
}


def parse_source(rd: TomlReader, raw, base_dir: Path) -> Source:
    """The checked ``[source]`` table."""
    table = rd.table(raw, "source")
    if "kind" not in table:
        raise rd.error("source.kind", f"required; one of {', '.join(map(repr, SOURCES))}")
    cls = SOURCES[rd.choice(table["kind"], "source.kind", tuple(SOURCES))]
    rd.keys(table, ("kind", *source_keys(cls)), "source")
    return cls.parse(rd, table, base_dir)


def source_keys(cls: type) -> tuple[str, ...]:
    """The TOML keys of a source class (its fields)."""
    return tuple(f.name for f in dataclasses.fields(cls))


def source_table(source: Source) -> dict:
    """The ``[source]`` table that parses back to ``source`` (paths absolute)."""
    table: dict[str, Any] = {"kind": source.kind}
    for f in dataclasses.fields(source):
        value = getattr(source, f.name)
        if value is None or value == () or (f.name == "spacing_mm" and not source.sample):
            continue
        table[f.name] = str(value) if isinstance(value, Path) else (
            list(value) if isinstance(value, tuple) else value)
    return table
