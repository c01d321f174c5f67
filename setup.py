"""The optional C extensions of inkarm: one control period of the simulated plant
(``inkarm/sim/_period.c``, used through :mod:`inkarm.sim.compiled`) and the built-in position
law's feed-forward and the member's period (``inkarm/control/_law.c``, ``_member.c``,
``_member_batch.c``, through
:mod:`inkarm.control.compiled`), and the felt-tip marker's pen between physics steps
(``inkarm/ink/_pen.c``, through :mod:`inkarm.ink.compiled_pen`), and the batched plant's physics
steps (``inkarm/sim/_batch.c``, through :mod:`inkarm.sim.batch_substeps`).

It compiles against the headers shipped with MuJoCo (the ``mujoco-core`` wheel, which the build
requirement ``mujoco>=4.0`` brings: the runtime's own requirement, so that a fresh install
resolves both alike) and records that version; at run time it is used only by the same MuJoCo.
It is ``optional``: without a C compiler (or the headers) the install goes on and the plant runs
its Python period. Everything else about the package is in pyproject.toml.
"""

import platform
from importlib.metadata import PackageNotFoundError, version
from importlib.util import find_spec
from pathlib import Path

from setuptools import Extension, setup


def _mujoco() -> tuple[Path, str] | None:
    """MuJoCo's header folder and version, without importing it (None: not installed)."""
    spec = find_spec("mujoco")
    if spec is None or not spec.submodule_search_locations:
        return None
    include = Path(next(iter(spec.submodule_search_locations))) / "include"
    for dist in ("mujoco-core", "mujoco"):  # (the library's own wheel since 4.0)
        try:
            return include, version(dist)
        except PackageNotFoundError:
            continue
    return None


def _extensions() -> list[Extension]:
    if platform.machine() not in ("x86_64", "AMD64"):
        # (its bits equal NumPy's only where NumPy's maximum/minimum break ties as x86's
        # maxsd/minsd do; elsewhere, aarch64's FMAX orders -0 below +0: the Python period runs)
        return []
    law = Extension("inkarm.control._law",
                    sources=["inkarm/control/_law.c", "inkarm/control/_member.c",
                             "inkarm/control/_member_batch.c"],
                    depends=["inkarm/control/_law.h", "inkarm/control/_member.h",
                             "inkarm/core/_plant.h"],
                    extra_compile_args=["-O2", "-ffp-contract=off"], optional=True)
    pen = Extension("inkarm.ink._pen", sources=["inkarm/ink/_pen.c"],
                    extra_compile_args=["-O2", "-ffp-contract=off"], optional=True)
    batch = Extension("inkarm.sim._batch", sources=["inkarm/sim/_batch.c"],
                      depends=["inkarm/sim/_drive.h"],
                      extra_compile_args=["-O2", "-ffp-contract=off"], optional=True)
    found = _mujoco()
    if found is None or not (found[0] / "mujoco" / "mujoco.h").is_file():
        return [law, pen, batch]  # (no MuJoCo headers: the plant's period in Python)
    include, mujoco_version = found
    return [law, pen, batch, Extension(
        "inkarm.sim._period",
        sources=["inkarm/sim/_period.c"],
        depends=["inkarm/core/_plant.h", "inkarm/sim/_drive.h"],
        include_dirs=[str(include)],
        define_macros=[("INKARM_MUJOCO_VERSION", f'"{mujoco_version}"')],
        extra_compile_args=["-O2", "-ffp-contract=off"],  # (no fused multiply-add: the same bits)
        libraries=["dl"],
        optional=True,
    )]


setup(ext_modules=_extensions())
