"""``inkarm pencil extract SCAN --out PROFILE`` and ``inkarm pencil show PROFILE --out DIR``:
the pencil texture statistics of seed 002 ch. 4 from a scanned line, and what they look like."""

from __future__ import annotations

import argparse
from pathlib import Path

from inkarm.commands import options_named
from inkarm.errors import InputError
from inkarm.io.outputs import atomic_file, check_out_dir, check_out_file, out_path, staged

SHOW_FILES = ("profile.png", "line.png")


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "pencil",
        help="pencil textures: extract a profile from a scanned line, show one",
        description="Pencil texture of the Human Line Algorithm (Al-Meraj 2008, ch. 4): 'extract' reads a greyscale scan of one "
        "straight pencil line and writes its profile (mid-line and whole-line histograms, "
        "co-occurrence matrices) for [ink] grade = \"PROFILE.npz\"; 'show' draws a profile "
        "(a shipped grade or a file) and a line synthesized from it beside its target scan.",
    )
    sub = p.add_subparsers(dest="action", required=True, metavar="{extract,show}")
    ex = sub.add_parser("extract", help="a profile from a scanned pencil line")
    ex.add_argument("scan", type=Path, help="greyscale image (PNG, TIFF, ...) of one straight "
                    "pencil line on white paper, any direction")
    ex.add_argument("--out", type=out_path, required=True, help="profile file to write (.npz)")
    ex.add_argument("--name", help="the pencil's name (default: the scan's file name)")
    ex.add_argument("--dpi", type=float, default=600.0,
                    help="resolution of the scan in [dots per inch] (default 600)")
    ex.add_argument("--force-n", type=float, default=1.0,
                    help="force the line was drawn with in [N], as far as known (default 1)")
    ex.add_argument("--levels", type=int, default=32,
                    help="grey-level bins of the co-occurrence matrices, 2 to 256 (default 32)")
    show = sub.add_parser("show", help="figure of a profile and a line synthesized from it")
    show.add_argument("profile", help="a shipped grade (2H, H, F, HB, B, 3B, 6B, 8B) or a "
                      "profile file")
    show.add_argument("--out", type=out_path, required=True,
                      help="folder for profile.png and line.png")
    show.add_argument("--length-mm", type=float, default=30.0,
                      help="length of the synthesized line in [mm] (default 30)")
    show.add_argument("--px-per-mm", type=float, default=None,
                      help="resolution of the synthesized line (default: the scan's)")
    show.add_argument("--seed", type=int, default=0, help="seed of the synthesis (default 0)")
    show.add_argument("--scan", type=Path, default=None,
                      help="the scanned line the profile was extracted from, shown beside the "
                      "synthesis as its target (default: a shipped grade's synthetic scan; "
                      "none for a profile file)")
    return p


def run(args: argparse.Namespace) -> int:
    return _extract(args) if args.action == "extract" else _show(args)


def _extract(args: argparse.Namespace) -> int:
    from inkarm.ink.pencil_extract import extract_profile, read_scan
    from inkarm.ink.pencil_profile import save_profile

    out = check_out_file(args.out, "profile", (".npz",), inputs=[args.scan])
    if not (args.dpi > 0 and args.dpi < 1e6):
        raise InputError(f"expected a resolution in (0, 1e6) dpi, got {args.dpi:g}",
                         key="--dpi", value=args.dpi)
    if not (args.force_n > 0 and args.force_n < 1e3):
        raise InputError(f"expected a force in (0, 1000) N, got {args.force_n:g}",
                         key="--force-n", value=args.force_n)
    grey = read_scan(args.scan)
    try:
        with options_named(levels="--levels"):
            profile = extract_profile(grey, name=args.name or args.scan.stem,
                                      px_per_mm=args.dpi / 25.4, levels=args.levels,
                                      reference_force_n=args.force_n, source=args.scan.name)
    except InputError as e:
        raise e.within(file=str(args.scan)) from None
    with atomic_file(out) as partial:
        save_profile(profile, partial)
    print(f"{profile.name}: width {profile.width_mm:.3f} mm, mid-line greys "
          f"{profile.mid_range}, line greys {profile.full_range}, {profile.levels} levels")
    print(f"profile written to {out} (use it with [ink] model = \"pencil\", grade = \"{out}\")")
    return 0


def _show(args: argparse.Namespace) -> int:
    import numpy as np
    from PIL import Image

    from inkarm.ink.pencil_profile import GRADES, resolve_profile
    from inkarm.ink.pencil_synthesis import synthesize_line
    from inkarm.ink.png import png_pixels
    from inkarm.plots.figure import save_figure
    from inkarm.plots.pencil import crop_line, plot_pencil_profile

    check_out_dir(args.out, inputs=[args.profile] + ([args.scan] if args.scan else []),
                  names=SHOW_FILES)
    if not 0 < args.length_mm <= 1000:
        raise InputError(f"expected a length in (0, 1000] mm, got {args.length_mm:g}",
                         key="--length-mm", value=args.length_mm)
    if args.px_per_mm is not None and not 0.5 <= args.px_per_mm <= 200:
        raise InputError(f"expected 0.5 to 200 px/mm, got {args.px_per_mm:g}",
                         key="--px-per-mm", value=args.px_per_mm)
    if args.seed < 0:
        raise InputError(f"expected a seed >= 0, got {args.seed}", key="--seed",
                         value=args.seed)
    with options_named(grade="PROFILE"):
        profile = resolve_profile(args.profile)
    ppm = args.px_per_mm or profile.px_per_mm
    rows = max(2, round(args.length_mm * ppm))
    scan = _target_scan(args.scan, args.profile, GRADES)
    texture = synthesize_line(profile, np.full(rows, profile.width_mm * ppm),
                              np.random.default_rng(args.seed))
    target = None if scan is None else crop_line(
        scan, rows / ppm, texture.mask.shape[1] / ppm, profile.px_per_mm)
    with staged(args.out, owned=SHOW_FILES) as stage:
        save_figure(plot_pencil_profile(profile, texture, target=target),
                    stage / "profile.png", dpi=120)
        Image.fromarray(png_pixels(texture.darkness.T)).save(stage / "line.png")
    print(f"{profile.name}: repair sweeps changed {list(texture.changes)} pixels; figures "
          f"written to {args.out}")
    return 0


def _target_scan(scan: Path | None, name: str, grades: tuple[str, ...]):
    """The upright scan to show beside the synthesis: ``scan`` when given (read and turned
    upright as extraction does), else a shipped grade's synthetic scan, else None."""
    from inkarm.ink.pencil_extract import read_scan, upright_line

    if scan is not None:
        try:
            return upright_line(read_scan(scan))
        except InputError as e:
            raise e.within(file=str(scan)) from None
    if name.upper() in grades:
        from inkarm.ink.graphite import reference_scan

        return upright_line(reference_scan(name.upper()))
    return None
