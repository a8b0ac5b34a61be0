"""Magnets and coils as field sources, and magpylib's field of them (SI).

magpylib (https://magpylib.readthedocs.io) is the source of truth for every magnet and coil field;
nothing here writes a magnet formula. Each source is centred in the rod's plane: a cylinder or
sphere magnet magnetised along its axis, a cuboid magnetised along an edge, a current loop, a
solenoid, a Helmholtz or a Maxwell pair (each with that axis in the plane), or a cylinder standing
on the plane magnetised across a diameter. Units: m, A/m, A, rad.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import List, Tuple

import numpy as np

__all__ = ["MagnetSource", "CoilSource", "MappedCoil", "TESSERAL_SHAPES", "loops", "radii", "plane_section",
           "sections_overlap", "magpylib_objects", "magpylib_field"]

#: magnets whose field is not axisymmetric about an axis in the plane: fitted by tesseral harmonics
TESSERAL_SHAPES = ("cuboid", "diametric_cylinder")


@dataclass(frozen=True)
class MagnetSource:
    """A permanent magnet magnetised along its axis (SI).

    shape : "cylinder", "sphere", "cuboid" or "diametric_cylinder" (a disc or cylinder standing on
    the rod's plane, its own axis normal to it, magnetised across a diameter: "axis" below is the
    magnetisation's direction); diameter (cylinders, sphere), height (cylinder and cuboid: the
    extent along the axis; diametric cylinder: out of the plane), width (cuboid: across the axis in
    the rod's plane) and thickness (cuboid: out of the plane) in m; position (x, y) of its
    centre in m (the clamp at the origin, the rod along +x, the magnet centred in the rod's plane);
    axis_angle : direction of its axis and magnetisation, rad from the rod axis; magnetization : M, A/m
    (a remanence B_r in tesla is M = B_r/μ0). travel : how far its stage can move it, for a design
    over its pose (:mod:`actuator_design.hardware.pose_design`): ((x_lo, x_hi), (y_lo, y_hi),
    (angle_lo, angle_hi)) in m and rad, ``None`` for a coordinate held; empty: the magnet is fixed. A
    magnet with travel is fitted down to its own body (not only over the rod's reach from where it
    is), so that its fitted field, moved rigidly, holds wherever the stage takes it.
    """

    shape: str
    diameter: float
    height: float
    position: Tuple[float, float]
    axis_angle: float
    magnetization: float
    travel: Tuple = ()
    width: float = 0.0
    thickness: float = 0.0


@dataclass(frozen=True)
class CoilSource:
    """Coaxial circular windings (SI): kind "loop" (``turns`` turns at one place), "solenoid"
    (``turns`` loops spread evenly over ``length``), "helmholtz" or "maxwell" (two windings of
    ``turns`` turns ``spacing`` apart, currents equal or opposite). ``current`` in A per turn.
    Hardware, for a design over currents (:mod:`actuator_design.hardware.current_design`):
    ``max_current`` (A, the driver's limit; inf: not given) and ``resistance`` (Ω of the whole
    coil; nan: not given)."""

    kind: str
    radius: float
    position: Tuple[float, float]
    axis_angle: float
    current: float
    turns: int = 1
    length: float = 0.0
    spacing: float = 0.0
    max_current: float = math.inf
    resistance: float = math.nan


@dataclass(frozen=True)
class MappedCoil(CoilSource):
    """A coil known by its measured field per ampere (a calibration map, :mod:`actuator_design.model.coil_map`),
    not by its windings: ``name`` its column prefix in the map file, ``points`` the map's sample
    positions (x, y, z) in m in the rod's frame (clamp at the origin, rod along +x, z = 0 its plane),
    ``field_per_amp`` H per ampere at each point, (Hx, Hy, Hz) in A/m per A (Hz NaN where the map
    has none). ``current``, ``max_current`` and ``resistance`` as for :class:`CoilSource`; magpylib
    has no part in its field (the map is its truth)."""

    kind: str = "map"
    radius: float = 0.0
    position: Tuple[float, float] = (0.0, 0.0)
    axis_angle: float = 0.0
    current: float = 0.0
    name: str = ""
    points: Tuple[Tuple[float, float, float], ...] = ()
    field_per_amp: Tuple[Tuple[float, float, float], ...] = ()


def loops(src: CoilSource) -> List[Tuple[float, float]]:
    """(axial offset m, ampere-turns) of each loop of a coil."""
    if src.kind == "loop":
        return [(0.0, src.current * src.turns)]
    if src.kind == "solenoid":
        n = src.turns
        offs = np.linspace(-0.5 * src.length, 0.5 * src.length, n) if n > 1 else np.zeros(1)
        return [(float(o), src.current) for o in offs]
    sign = -1.0 if src.kind == "maxwell" else 1.0
    return [(-0.5 * src.spacing, src.current * src.turns), (0.5 * src.spacing, sign * src.current * src.turns)]


def plane_section(src: MagnetSource) -> np.ndarray:
    """The magnet's section by the rod's plane, a convex polygon (m), shape (k, 2): a rectangle for
    a cylinder (height × diameter) or a cuboid (height × width), an inscribed 180-gon for a sphere or a
    diametric cylinder. The magnets are convex and symmetric in the plane, so two of them overlap
    exactly when their sections do (a common point (x, y, z) gives (x, y, −z), and the midpoint)."""
    c = np.asarray(src.position, float)
    e = np.array([math.cos(src.axis_angle), math.sin(src.axis_angle)])
    n = np.array([-e[1], e[0]])
    if src.shape in ("sphere", "diametric_cylinder"):
        a = np.linspace(0.0, 2 * np.pi, 180, endpoint=False)
        return c + 0.5 * src.diameter * np.column_stack([np.cos(a), np.sin(a)])
    half_across = 0.5 * (src.width if src.shape == "cuboid" else src.diameter)
    corners = ((-1, -1), (1, -1), (1, 1), (-1, 1))
    return np.array([c + i * 0.5 * src.height * e + j * half_across * n for i, j in corners])


def sections_overlap(a: np.ndarray, b: np.ndarray, tol: float) -> bool:
    """Whether two convex polygons (k, 2) overlap by more than ``tol`` (m) along every separating
    axis candidate (their edges' normals): touching faces do not overlap."""
    for poly in (a, b):
        edges = np.roll(poly, -1, axis=0) - poly
        for nx, ny in np.column_stack([-edges[:, 1], edges[:, 0]]):
            norm = math.hypot(nx, ny)
            if norm == 0.0:
                continue
            pa, pb = a @ (nx / norm, ny / norm), b @ (nx / norm, ny / norm)
            if min(pa.max(), pb.max()) - max(pa.min(), pb.min()) <= tol:
                return False
    return True


def radii(src) -> Tuple[float, float]:
    """(R_v, R_i), m: the sphere about the centre holding every source, the ball free of them."""
    if isinstance(src, MagnetSource) and src.shape == "cuboid":
        return 0.5 * math.sqrt(src.height ** 2 + src.width ** 2 + src.thickness ** 2), 0.0
    if isinstance(src, MagnetSource) and src.shape == "diametric_cylinder":
        return 0.5 * math.hypot(src.diameter, src.height), 0.0
    if isinstance(src, MagnetSource):
        h = 0.0 if src.shape == "sphere" else 0.5 * src.height
        r = math.hypot(0.5 * src.diameter, h)
        return r, (0.0 if src.shape == "cylinder" else 0.5 * src.diameter)
    d = [math.hypot(src.radius, off) for off, _ in loops(src)]
    return max(d), min(d)


def magpylib_objects(src):
    """The magpylib sources of one source, placed and oriented (its axis along the local z)."""
    import magpylib as magpy
    from scipy.spatial.transform import Rotation

    rot = Rotation.from_euler("yz", [90.0, math.degrees(src.axis_angle)], degrees=True)  # z → axis
    pos = np.array([src.position[0], src.position[1], 0.0])
    axis = rot.apply([0.0, 0.0, 1.0])
    if isinstance(src, MagnetSource) and src.shape == "diametric_cylinder":  # its own axis stays z
        obj = magpy.magnet.Cylinder(dimension=(src.diameter, src.height), magnetization=(src.magnetization, 0, 0))
        obj.orientation = Rotation.from_euler("z", src.axis_angle)
        obj.position = pos
        return [obj]
    if isinstance(src, MagnetSource):
        if src.shape == "sphere":
            obj = magpy.magnet.Sphere(diameter=src.diameter, magnetization=(0, 0, src.magnetization))
        elif src.shape == "cuboid":  # local x is out of the plane, local y across the axis
            obj = magpy.magnet.Cuboid(dimension=(src.thickness, src.width, src.height),
                                      magnetization=(0, 0, src.magnetization))
        else:
            obj = magpy.magnet.Cylinder(dimension=(src.diameter, src.height),
                                        magnetization=(0, 0, src.magnetization))
        obj.orientation = rot
        obj.position = pos
        return [obj]
    out = []
    for off, amp_turns in loops(src):
        loop = magpy.current.Circle(diameter=2 * src.radius, current=amp_turns)
        loop.orientation = rot
        loop.position = pos + off * axis
        out.append(loop)
    return out


def magpylib_field(sources, points_m: np.ndarray) -> np.ndarray:
    """H (A/m), shape (n, 3), of ``sources`` at ``points_m`` (shape (n, 3), m), by magpylib."""
    import magpylib as magpy

    objs = [o for s in sources for o in magpylib_objects(s)]
    return np.asarray(magpy.getH(objs, np.asarray(points_m, float), sumup=True), float).reshape(-1, 3)
