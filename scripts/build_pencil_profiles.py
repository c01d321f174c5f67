"""Build the shipped pencil profiles (inkarm/data/pencils/<grade>.npz) from the graphite model.

No public scans of pencil lines exist (seed 002 ch. 4.1 used the author's own), so each grade's
profile is extracted, by the same code a user's scan goes through (``inkarm pencil extract``),
from a synthetic 600 dpi scan of a 40 mm line that :mod:`inkarm.ink.graphite` renders at the
reference force. Deterministic: run it again and the files are the same.

    .venv/bin/python scripts/build_pencil_profiles.py [OUT_DIR]
"""

from __future__ import annotations

import sys
from pathlib import Path

from inkarm.ink.graphite import REFERENCE_FORCE_N, reference_scan
from inkarm.ink.pencil_extract import SCAN_PX_PER_MM, extract_profile
from inkarm.ink.pencil_profile import GRADES, save_profile

LENGTH_MM = 40.0


def main(out_dir: Path) -> None:
    out_dir.mkdir(parents=True, exist_ok=True)
    for grade in GRADES:
        scan = reference_scan(grade, LENGTH_MM)
        profile = extract_profile(
            scan, name=grade, px_per_mm=SCAN_PX_PER_MM, reference_force_n=REFERENCE_FORCE_N,
            source=f"synthetic scan of the graphite model (inkarm.ink.graphite), grade {grade}, "
                   f"{LENGTH_MM:g} mm at {REFERENCE_FORCE_N:g} N, 600 dpi; not a real pencil")
        path = save_profile(profile, out_dir / f"{grade}.npz")
        print(f"{grade}: width {profile.width_mm:.3f} mm, mid-line greys {profile.mid_range}, "
              f"line greys {profile.full_range} -> {path}")


if __name__ == "__main__":
    default = Path(__file__).resolve().parent.parent / "inkarm" / "data" / "pencils"
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else default)
