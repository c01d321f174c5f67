"""Arms read from a local MuJoCo Menagerie copy named by ``$MENAGERIE_ROOT``.

The model is loaded meshes and all and fitted to the drawing cell: its position actuators,
keyframes, lights and contact pairs go; a torque motor per arm joint (``motor1..n``) saturating
at the profile's torque limits drives it; joints without armature or damping get the given
defaults (the joint PID relies on reflected rotor inertia and some viscous friction); none of its
geoms collides with anything; the pen is mounted on the flange site the profile names.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import mujoco

from inkarm.errors import InputError
from inkarm.robots.arms.iiwa14 import add_motor

MENAGERIE_ROOT_VARIABLE = "MENAGERIE_ROOT"


def model_path(relative: str) -> Path:
    """``$MENAGERIE_ROOT/relative``; InputError when the variable is unset or the file
    missing."""
    root = os.environ.get(MENAGERIE_ROOT_VARIABLE, "")
    if not root:
        raise InputError(
            f"loads a MuJoCo Menagerie model: set the environment variable "
            f"{MENAGERIE_ROOT_VARIABLE} to a local copy of mujoco_menagerie "
            f"(expected ${MENAGERIE_ROOT_VARIABLE}/{relative})", key="model.menagerie",
            value=relative,
        )
    path = Path(root).expanduser() / relative
    if not path.is_file():
        raise InputError(
            f"no file {path} ({MENAGERIE_ROOT_VARIABLE}={root!r}; expected "
            f"${MENAGERIE_ROOT_VARIABLE}/{relative} from mujoco_menagerie)",
            key="model.menagerie", value=relative,
        )
    return path


def load_spec(relative: str) -> mujoco.MjSpec:
    """The Menagerie model at ``relative``, checked for missing meshes."""
    path = model_path(relative)
    try:
        spec = mujoco.MjSpec.from_file(str(path))
    except ValueError as e:
        raise InputError(f"cannot read {path}: {e}", key="model.menagerie") from None
    # A copy without its meshes (a sparse checkout, an interrupted download) fails at compile
    # time with a terse message: name the first missing file here instead.
    mesh_dir = Path(spec.modelfiledir) / spec.meshdir
    for mesh in spec.meshes:
        if mesh.file and not (mesh_dir / mesh.file).is_file():
            raise InputError(
                f"{path} needs the mesh {mesh_dir / mesh.file}, which is missing (an "
                "incomplete copy of mujoco_menagerie?)", key="model.menagerie",
            )
    return spec


def fit_arm(
    spec: mujoco.MjSpec,
    relative: str,
    joint_names: Sequence[str],
    torque_limits_nm: Sequence[float],
    flange_site: str,
    armature: Sequence[float],
    damping: Sequence[float],
) -> mujoco.MjsFrame:
    """Fit a freshly loaded Menagerie arm to the cell (module docstring); returns the frame of
    its ``flange_site``."""
    where = f"model.menagerie = {relative!r}"
    # inkarm's controller commands torques, Menagerie's models have position servos; their
    # keyframes carry their controls and no pen slide, and the cell brings its own light.
    for element in [*spec.actuators, *spec.keys, *spec.lights, *spec.pairs]:
        spec.delete(element)
    for geom in spec.geoms:  # only the pen tip and the paper may touch
        geom.contype = 0
        geom.conaffinity = 0
    joints = {joint.name: joint for joint in spec.joints}
    missing = [name for name in joint_names if name not in joints]
    extra = sorted(set(joints) - set(joint_names))
    if missing or extra:
        raise InputError(
            f"{where}: expected exactly the hinge joints {', '.join(joint_names)}; "
            f"missing {missing}, unexpected {extra}", key="joints",
        )
    for i, name in enumerate(joint_names):
        joint = joints[name]
        if joint.type != mujoco.mjtJoint.mjJNT_HINGE:
            raise InputError(f"{where}: joint {name!r} is not a hinge", key="joints")
        if joint.armature == 0.0:
            joint.armature = armature[i]
        if joint.damping[0] == 0.0:
            joint.damping = [damping[i], *joint.damping[1:]]
        add_motor(spec, f"motor{i + 1}", name, torque_limits_nm[i])
    site = spec.site(flange_site)
    if site is None:
        raise InputError(f"{where}: no site {flange_site!r} to mount the pen on",
                         key="model.flange_site", value=flange_site)
    flange = site.parent.add_frame(pos=site.pos, quat=site.quat)
    flange.alt = site.alt  # the site's orientation, if given as euler, axisangle, ...
    return flange
