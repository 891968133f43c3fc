"""Robot model files: find a URDF (a path, or a robot shipped with hybridsim or example-robot-data),
check it, and load it with Pinocchio (``pip install "hybridsim[robots]"``), once per file."""
import contextlib
import functools
import os
import re
import sys
import tempfile
from pathlib import Path
from xml.etree import ElementTree

import numpy as np

from hybridsim.errors import ParameterError

from hybridsim.blocks.robot import kernels as rk, rigid


#: robots shipped with hybridsim (its diagrams/robots folder)
OWN_ROBOTS = {"fig3_arm": "fig3_arm.urdf"}
#: example-robot-data's URDFs by short name (under its share/example-robot-data/robots)
ROBOTS = {
    "ur3": "ur_description/urdf/ur3_robot.urdf",
    "ur5": "ur_description/urdf/ur5_robot.urdf",
    "ur10": "ur_description/urdf/ur10_robot.urdf",
    "panda": "panda_description/urdf/panda.urdf",
    "kinova": "kinova_description/robots/kinova.urdf",
    "iiwa": "iiwa_description/urdf/iiwa.urdf",
}


def _pinocchio():
    try:
        import pinocchio
    except ImportError:
        raise ParameterError("urdf", "robot blocks need Pinocchio: pip install \"hybridsim[robots]\" "
                                     "(the PyPI packages pin and example-robot-data)") from None
    return pinocchio


def robots_folder():
    """example-robot-data's robots folder (``share/example-robot-data/robots`` under its prefix), or None."""
    from importlib.metadata import PackageNotFoundError, distribution

    try:
        dist = distribution("example-robot-data")
    except PackageNotFoundError:
        return None
    for rel in ("cmeel.prefix/share/example-robot-data/robots", "share/example-robot-data/robots"):
        folder = Path(dist.locate_file(rel))
        if folder.is_dir():
            return folder
    return None


def urdf_path(urdf=None, robot=None):
    """The URDF file a block loads: ``urdf`` (a path) or ``robot`` (a name of :data:`ROBOTS`)."""
    if (urdf is None) == (robot is None):
        raise ParameterError("urdf", "give a URDF file (urdf: path/arm.urdf) or a shipped robot "
                                     f"(robot: one of {', '.join([*OWN_ROBOTS, *ROBOTS])}), one of them")
    if robot is not None:
        if robot in OWN_ROBOTS:
            from hybridsim.shipped import diagrams_folder

            return diagrams_folder() / "robots" / OWN_ROBOTS[robot]
        if robot not in ROBOTS:
            raise ParameterError("robot", f"unknown robot {robot!r}; shipped: {', '.join([*OWN_ROBOTS, *ROBOTS])} "
                                          "(or give urdf: path/to/your.urdf)")
        folder = robots_folder()
        if folder is None:
            raise ParameterError("robot", "needs the example-robot-data package: pip install \"hybridsim[robots]\"")
        path = folder / ROBOTS[robot]
        if not path.is_file():
            raise ParameterError("robot", f"{robot!r}: this example-robot-data has no {ROBOTS[robot]} "
                                          "(give urdf: path/to/your.urdf)")
        return path
    path = Path(str(urdf)).expanduser()
    if not path.is_file():
        raise ParameterError("urdf", f"file not found: {str(path)!r} (a relative path is from the working folder)")
    return path


@functools.lru_cache(maxsize=16)
def _load(path, mtime):
    pin = _pinocchio()
    try:
        tree = ElementTree.parse(path)
    except ElementTree.ParseError as exc:
        line, column = exc.position
        raise ParameterError("urdf", f"{str(path)}:{line}: not well-formed XML (column {column + 1}): "
                                     f"{str(exc).split(':')[0]}") from None
    _check_urdf(tree, path)
    with _said_in_c() as said:  # urdfdom says why a file is not a URDF on stderr, Pinocchio only that it is not
        try:
            model = pin.buildModelFromUrdf(str(path))
        except Exception as exc:  # noqa: BLE001 - Pinocchio raises plain errors
            model = exc
    if isinstance(model, Exception):
        why = "; ".join(m.strip() for m in re.findall(r"Error:(.*)", said[0]))
        raise ParameterError("urdf", f"{str(path)!r} is not a robot model Pinocchio can read: {model}"
                                     + (f" ({why})" if why else ""))
    if said[0]:
        sys.stderr.write(said[0])  # not an error: passed on
    if model.nv == 0:
        raise ParameterError("urdf", f"{str(path)!r} has no moving joint")
    odd = [f"{model.names[j]!r} ({_kind(model.joints[j].shortname())})"
           for j in range(1, model.njoints) if model.joints[j].shortname() not in rigid.JOINTS]
    if odd:
        raise ParameterError("urdf", f"{str(path)!r}: only revolute and prismatic joints are supported; "
                                     f"not {', '.join(odd[:4])}" + (f" and {len(odd) - 4} more" if len(odd) > 4 else ""))
    return model


#: the numeric attributes urdfdom reads, by element: how many numbers each holds
NUMBERS = {
    "mass": {"value": 1}, "inertia": dict.fromkeys(("ixx", "ixy", "ixz", "iyy", "iyz", "izz"), 1),
    "origin": {"xyz": 3, "rpy": 3}, "axis": {"xyz": 3},
    "limit": dict.fromkeys(("lower", "upper", "effort", "velocity"), 1), "dynamics": {"damping": 1, "friction": 1},
    "mimic": {"multiplier": 1, "offset": 1}, "box": {"size": 3}, "cylinder": {"radius": 1, "length": 1},
    "sphere": {"radius": 1}, "mesh": {"scale": 3},
    "safety_controller": dict.fromkeys(("soft_lower_limit", "soft_upper_limit", "k_position", "k_velocity"), 1),
}


#: attributes without which urdfdom reads the element as zero
REQUIRED = {"mass": ("value",), "inertia": ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
#: a number as urdfdom reads one: ASCII digits, nothing around it
_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?", re.ASCII)


def _check_numbers(path):
    """ParameterError at the line of the first numeric attribute that is not its count of numbers
    (urdfdom reads ``2.O`` as a mass of 0 and goes on, saying so only on stderr)."""
    from xml.parsers import expat

    bad = []
    parser = expat.ParserCreate()

    def start(tag, attrs):
        for key, n in NUMBERS.get(tag, {}).items():
            if bad:
                return
            if key not in attrs:
                if key in REQUIRED.get(tag, ()):  # urdfdom reads it as 0
                    bad.append((parser.CurrentLineNumber, tag, key, None, n))
                continue
            words = attrs[key].split() if n > 1 else [attrs[key]]  # one number: no spaces around it either
            ok = len(words) == n and all(_NUMBER.fullmatch(w) and np.isfinite(float(w)) for w in words)
            if ok and tag == "inertia" and key in ("ixx", "iyy", "izz") and float(words[0]) < -1e-9:
                bad.append((parser.CurrentLineNumber, tag, key, attrs[key], "a moment of inertia >= 0"))
            elif not ok:
                bad.append((parser.CurrentLineNumber, tag, key, attrs[key], n))

    parser.StartElementHandler = start
    with open(path, "rb") as fh:
        parser.ParseFile(fh)
    if bad:
        line, tag, key, value, n = bad[0]
        what = n if isinstance(n, str) else "a number" if n == 1 else f"{n} numbers"
        if value is None:
            raise ParameterError("urdf", f"{str(path)}:{line}: <{tag}> has no {key} (Pinocchio would read 0)")
        raise ParameterError("urdf", f"{str(path)}:{line}: <{tag}> {key}={value!r} is not {what}")


def _check_urdf(tree, path):
    """Refuse what Pinocchio takes but cannot simulate: a number it cannot read, a moving joint's zero
    axis, a negative mass."""
    _check_numbers(path)
    for j in tree.iter("joint"):
        axis = j.find("axis")
        if j.get("type") in ("revolute", "continuous", "prismatic") and axis is not None:
            try:
                xyz = [float(v) for v in axis.get("xyz", "1 0 0").split()]
            except ValueError:
                xyz = [1.0]
            if not any(xyz):
                raise ParameterError("urdf", f"{str(path)!r}: joint {j.get('name')!r} has a zero axis (xyz 0 0 0)")
    for link in tree.iter("link"):
        mass = link.find("inertial/mass")
        try:
            m = float(mass.get("value")) if mass is not None else 0.0
        except (TypeError, ValueError):
            continue  # Pinocchio names a mass it cannot read
        if m < 0:
            raise ParameterError("urdf", f"{str(path)!r}: link {link.get('name')!r} has a negative mass ({m:g} kg)")


@contextlib.contextmanager
def _said_in_c():
    """What C code writes on file descriptor 2 inside the block: ``[text]`` after it."""
    said = []
    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile() as tmp:
        os.dup2(tmp.fileno(), 2)
        try:
            yield said
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            said.append(tmp.read().decode(errors="replace"))


def _kind(joint_type):
    """What a Pinocchio joint type is, in words, for the message that refuses it."""
    words = {"JointModelRUB": "continuous: an unbounded revolute joint", "JointModelFreeFlyer": "a floating base",
             "JointModelPlanar": "planar", "JointModelSpherical": "spherical"}
    return joint_type + next((f", {w}" for k, w in words.items() if joint_type.startswith(k)), "")


def load_model(path):
    """The Pinocchio model of a URDF file (cached per file and modification time; never modify it)."""
    path = Path(path).resolve()
    return _load(path, path.stat().st_mtime)


def model_number(path, gravity=None):
    """The number of the model of URDF ``path`` (with ``gravity``, m/s^2, when given) among the
    fused path's Pinocchio models (:func:`hybridsim.blocks.robot.kernels.pinocchio_model`): one
    model per file and gravity, shared by every block that names them."""
    path = Path(path).resolve()
    model = load_model(path)
    key = (str(path), path.stat().st_mtime, None if gravity is None else tuple(float(g) for g in gravity))
    if gravity is not None:
        model = model.copy()
        model.gravity.linear = np.asarray(gravity, float)
    return rk.pinocchio_model(model, key)
