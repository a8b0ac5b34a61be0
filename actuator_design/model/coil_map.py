"""Coils known by a calibration map: their field per ampere read from a file and fitted.

An electromagnetic navigation system is calibrated coil by coil: B(x) = Σ_k b_k(x) I_k, each b_k
measured (or computed) per ampere on a grid of its workspace. A map file is CSV, one row a point,
each column header ``name [unit]``:

    # any comment lines
    x [mm], y [mm], z [mm], c1_bx [mT/A], c1_by [mT/A], c1_bz [mT/A], c2_bx [mT/A], ...

``x``, ``y`` (and optionally ``z``) in the rod's frame (the clamp at the origin, the rod along +x,
z = 0 its plane), and per coil ``<name>_bx``, ``<name>_by`` (and ``<name>_bz`` when z is given) in
a field unit per ampere (``mT/A``, ``T/A``, ``kA/m/A``, ...).

Each coil's map is fitted by least squares with the interior solid harmonics of
:mod:`actuator_design.physics.tesseral` that are mirror symmetric in the rod's plane (the planar
model holds only in a plane of symmetry: no field normal to it). The field is divergence- and
curl-free by construction; a map that is not (noise, a field normal to the plane) shows as misfit.
The fit is made per ampere; its order is the lowest whose fit, made without every fourth distinct
point, meets ``fit_tolerance`` on those held-out points; the reported error is that held-out error
at the coil's current. The fit holds in the disc inscribed in the map's extent in the plane, shrunk
to where the points cover it (no test point farther than 1.5 median spacings from a map point). A
map has no gradient samples: the gradient's error is not measured (NaN). A map without z says
nothing about the field normal to the plane: its symmetry is then assumed, not checked.
"""
from __future__ import annotations

import csv
import functools
import math
import os
import re
from dataclasses import dataclass, replace
from typing import Dict, Tuple

import numpy as np

from actuator_design.calibration.data import read_bounded_text  # bounded, regular files only
from actuator_design.model.source_fit import FittedField, reach_grid
from actuator_design.model.sources import MappedCoil
from actuator_design.model.units import QuantityError, parse_quantity
from actuator_design.physics.harmonic import field_function
from actuator_design.physics.tesseral import TesseralTerm, interior_modes, tesseral_potentials

__all__ = ["CoilMap", "read_coil_map", "fit_map", "MAX_MAP_ORDER", "MAX_MAP_ROWS", "MAX_MAP_COILS"]

#: The highest degree a map is fitted with (l(l + 3)/2 = 324 terms a coil).
MAX_MAP_ORDER = 24
#: The most points a map may have, and the most coils.
MAX_MAP_ROWS = 20000
MAX_MAP_COILS = 16
#: The farthest a map's point may lie from the clamp (m), and the largest field per ampere (A/m per A,
#: ~1.3 kT/A: far beyond any coil; it keeps squares and sums finite)
MAX_POSITION = 1e3
MAX_FIELD_PER_AMP = 1e9

_HEADER = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)\s*\[([^\]]*)\]\s*$")
_COMPONENT = re.compile(r"^([A-Za-z][A-Za-z0-9]*)_b([xyz])$")


@dataclass(frozen=True)
class CoilMap:
    """A calibration map, SI: ``points`` (n, 3) m (z = 0 where the file has no z) and per coil name
    its H per ampere, (n, 2) or (n, 3) A/m per A (3 columns when the file gives z)."""

    source: str
    points: np.ndarray
    fields: Dict[str, np.ndarray]

    @property
    def names(self) -> Tuple[str, ...]:
        return tuple(self.fields)


def _unit_factor(unit: str, column: str, source: str) -> float:
    """SI factor of a column's unit: a length (x, y, z) or a field per ampere (A/m per A)."""
    where = f"{source}: column '{column}'"
    try:
        if column in ("x", "y", "z"):
            return parse_quantity(f"1 {unit}", "length", column)
        per_amp = unit.replace(" ", "")
        if not per_amp.endswith("/A"):
            raise QuantityError(column, f"unit {unit!r} is not a field per ampere (e.g. mT/A, T/A, kA/m/A)")
        try:
            return parse_quantity(f"1 {per_amp[:-2]}", "magnetic_field", column)
        except QuantityError:
            raise QuantityError(column, f"unit {unit!r} is not a field per ampere (e.g. mT/A, T/A, kA/m/A)") from None
    except QuantityError as err:
        raise ValueError(f"{where}: {err.detail}") from None


def parse_coil_map(text: str, source: str = "<map>") -> CoilMap:
    """A :class:`CoilMap` from CSV text (module docstring); every problem is one ValueError line
    naming the file, the column and the row."""
    header, rows = None, []
    for lineno, line in enumerate(text.splitlines(), start=1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        cells = next(csv.reader([line], skipinitialspace=True))
        if header is None:
            header = []
            for cell in cells:
                m = _HEADER.match(cell)
                if not m:
                    raise ValueError(f"{source}: line {lineno}: cannot read column header {cell.strip()[:40]!r} "
                                     "(expected 'name [unit]', e.g. 'x [mm]' or 'c1_bx [mT/A]')")
                name = m.group(1)
                if name not in ("x", "y", "z") and not _COMPONENT.match(name):
                    raise ValueError(f"{source}: column '{name}': unknown column (expected x, y, z and <coil>_bx, "
                                     "<coil>_by, <coil>_bz)")
                if not m.group(2).strip():
                    raise ValueError(f"{source}: column '{name}': give its unit in the brackets (e.g. "
                                     f"'{name} [{'mm' if name in ('x', 'y', 'z') else 'mT/A'}]')")
                header.append((name, _unit_factor(m.group(2).strip(), name, source)))
            continue
        if len(rows) >= MAX_MAP_ROWS:
            raise ValueError(f"{source}: more than {MAX_MAP_ROWS} points (thin the map)")
        if len(cells) != len(header):
            raise ValueError(f"{source}: line {lineno}: expected {len(header)} values (one per header column), "
                             f"got {len(cells)}")
        row = []
        for (name, factor), cell in zip(header, cells):
            try:
                v = float(cell)
            except ValueError:
                v = math.nan
            if not math.isfinite(v):
                raise ValueError(f"{source}: column '{name}', line {lineno}: not a finite number: {cell.strip()[:20]!r}")
            row.append(v * factor)
        rows.append(row)
    if header is None:
        raise ValueError(f"{source}: no header line (expected e.g. 'x [mm], y [mm], c1_bx [mT/A], c1_by [mT/A]')")
    names = [n for n, _ in header]
    for n in names:
        if names.count(n) > 1:
            raise ValueError(f"{source}: column '{n}' appears twice in the header")
    for n in ("x", "y"):
        if n not in names:
            raise ValueError(f"{source}: no column '{n}' (the points' position, e.g. '{n} [mm]')")
    table = np.asarray(rows, float).reshape(len(rows), len(names))
    col = {n: table[:, j] for j, n in enumerate(names)}
    with_z = "z" in col
    coils = list(dict.fromkeys(_COMPONENT.match(n).group(1) for n in names if n not in ("x", "y", "z")))
    if not coils:
        raise ValueError(f"{source}: no coil columns (expected <coil>_bx and <coil>_by, e.g. 'c1_bx [mT/A]')")
    if len(coils) > MAX_MAP_COILS:
        raise ValueError(f"{source}: {len(coils)} coils; at most {MAX_MAP_COILS}")
    fields = {}
    for c in coils:
        need = ("x", "y", "z") if with_z else ("x", "y")
        for a in ("x", "y", "z"):
            if (f"{c}_b{a}" in col) != (a in need):
                problem = "has no" if a in need else "has a"
                why = "z is given" if with_z else "the map has no z column (points in the rod's plane)"
                raise ValueError(f"{source}: coil '{c}' {problem} column '{c}_b{a}' ({why})")
        fields[c] = np.column_stack([col[f"{c}_b{a}"] for a in need])
    points = np.column_stack([col["x"], col["y"], col["z"] if with_z else np.zeros(len(rows))])
    if len(rows) < 12:
        raise ValueError(f"{source}: {len(rows)} points; a map needs at least 12 (it is fitted with some held out)")
    far = np.max(np.abs(points))
    if far > MAX_POSITION:
        raise ValueError(f"{source}: a point lies {far:.3g} m from the clamp; the map's points must lie within "
                         f"{MAX_POSITION:g} m (check the position unit)")
    for name, f in fields.items():
        big = float(np.max(np.abs(f)))
        if big > MAX_FIELD_PER_AMP:
            raise ValueError(f"{source}: coil '{name}': a field of {big:.3g} A/m per A; at most {MAX_FIELD_PER_AMP:g} "
                             "A/m per A (check the field unit)")
    span = np.ptp(points[:, :2], axis=0)
    if not np.all(span > 0):
        raise ValueError(f"{source}: the points span no area in the rod's plane (x over {span[0]:.3g} m, y over "
                         f"{span[1]:.3g} m): a map needs a grid in x and y")
    return CoilMap(source, points, fields)


@functools.lru_cache(maxsize=8)
def _read_cached(path: str, mtime_ns: int, ctime_ns: int, inode: int, size: int) -> CoilMap:
    return parse_coil_map(read_bounded_text(path), source=os.path.basename(path))


def read_coil_map(path) -> CoilMap:
    """Read a map file (at most 16 MiB of UTF-8 CSV; module docstring); one ValueError line on any
    problem. A file read before and unchanged since (size, inode, modification and change times)
    is not read again."""
    path = os.fspath(path)
    try:
        info = os.stat(path)
    except OSError as err:
        raise ValueError(f"{path}: map file not found" if isinstance(err, FileNotFoundError)
                         else f"{path}: cannot read: {err.strerror or err}") from None
    return _read_cached(os.path.abspath(path), info.st_mtime_ns, info.st_ctime_ns, info.st_ino, info.st_size)


def _region(src: MappedCoil, length: float):
    """(centre (ℓ), radius where the map holds (ℓ), normalising radius (ℓ)) of a coil's map: the disc
    inscribed in the points' extent in the plane, shrunk to where the points cover it — every point
    of a test grid within 1.5 median spacings of a map point (a map with a hole holds only inside
    it). ValueError when no disc about the centre is covered."""
    from scipy.spatial import cKDTree

    p = np.asarray(src.points, float) / length
    flat = np.unique(p[:, :2], axis=0)
    lo, hi = flat.min(0), flat.max(0)
    c = 0.5 * (lo + hi)
    inscribed = 0.5 * float(np.min(hi - lo))
    tree = cKDTree(flat)
    spacing = float(np.median(tree.query(flat, k=2)[0][:, 1]))
    step = max(0.5 * spacing, inscribed / 200)  # at most 401 × 401 test points
    g = np.arange(-inscribed, inscribed + 0.5 * step, step)
    a, b = (v.ravel() for v in np.meshgrid(g, g))
    inside = a * a + b * b <= inscribed ** 2
    test = np.column_stack([c[0] + a[inside], c[1] + b[inside]])
    gap = tree.query(test)[0] > 1.5 * spacing
    radius = inscribed
    if np.any(gap):
        radius = min(inscribed, float(np.min(np.hypot(*(test[gap] - c).T))) - spacing)
    if not radius > 0:
        raise ValueError(f"coil '{src.name}': the map's points leave a gap at the centre of their extent "
                         f"({c[0] * length * 1e3:.4g}, {c[1] * length * 1e3:.4g}) mm: a map needs a grid over its region")
    big = float(np.max(np.linalg.norm(p - [c[0], c[1], 0.0], axis=1)))
    return (float(c[0]), float(c[1])), radius, big


def _gradients(c, radius: float, modes, pts: np.ndarray, with_z: bool) -> np.ndarray:
    """−∇ of each unit mode at ``pts`` (n, 3) ℓ: shape (n·d, modes), d = 3 or 2 (x, y only)."""
    import casadi as ca

    x, y, z = ca.SX.sym("x"), ca.SX.sym("y"), ca.SX.sym("z")
    psi = ca.vertcat(*tesseral_potentials(c, 0.0, radius, modes, x, y, z, kind="interior"))
    wrt = [x, y, z] if with_z else [x, y]
    jac = -ca.jacobian(psi, ca.vertcat(*wrt))  # (modes, d)
    fn = ca.Function("map_basis", [x, y, z], [jac.T]).map(len(pts))
    out = np.asarray(fn(pts[:, 0], pts[:, 1], pts[:, 2]), float)  # (d, modes·n)
    d = len(wrt)
    return out.reshape(d, len(pts), len(modes)).transpose(1, 0, 2).reshape(len(pts) * d, len(modes))


def _fit_coil(src: MappedCoil, length: float, tol: float):
    """(term with coefficients in A/m per A, held-out error A/m per A, order) of one mapped coil:
    fitted per ampere (its order does not depend on its current), every fourth distinct point held
    out (a point listed twice is held out with its twin)."""
    c, region, radius = _region(src, length)
    pts = np.asarray(src.points, float) / length
    data = np.asarray(src.field_per_amp, float)
    with_z = data.shape[1] == 3
    scale = float(np.max(np.linalg.norm(data, axis=1)))
    if not scale > 0:
        raise ValueError(f"coil '{src.name}' has no field in its map")
    n, d = len(pts), data.shape[1]
    # every fourth distinct point in the file's order (not in a sorted order, which round-off in
    # the coordinates would change), with its twins
    _, first, inverse = np.unique(pts, axis=0, return_index=True, return_inverse=True)
    rank = np.empty(len(first), int)
    rank[np.argsort(first)] = np.arange(len(first))
    held = rank[inverse.ravel()] % 4 == 3
    top = 1
    while top < MAX_MAP_ORDER and len(interior_modes(top + 1)) <= (n - held.sum()) * d // 2:
        top += 1
    modes = interior_modes(top)
    G = _gradients(c, radius, modes, pts, with_z)
    rows_held = np.repeat(held, d)
    target = data.ravel() / scale
    best = None
    for order in range(1, top + 1):
        k = len(interior_modes(order))
        a = np.linalg.lstsq(G[~rows_held, :k], target[~rows_held], rcond=None)[0]
        miss = float(np.max(np.linalg.norm((G[rows_held, :k] @ a - target[rows_held]).reshape(-1, d), axis=1)))
        if best is None or miss < best[0]:
            best = (miss, order)
        if miss <= tol:
            best = (miss, order)
            break
    miss, order = best
    if miss > tol:
        plane = "" if with_z else " (with no z in the map, its points must lie in the rod's plane)"
        raise ValueError(f"coil '{src.name}': its map is not represented to fit_tolerance {tol:g} by a field "
                         f"symmetric about the rod's plane: the best fit (order {order}) misses held-out samples by "
                         f"{miss:.2g} of its largest field; the map is noisy, coarse, or has a field normal to "
                         f"the plane{plane} (raise fit_tolerance to at least {miss:.2g} to accept it)")
    k = len(interior_modes(order))
    a = np.linalg.lstsq(G[:, :k], target, rcond=None)[0] * scale
    term = TesseralTerm("interior", c, 0.0, radius, tuple(float(v) for v in a), region, interior_modes(order))
    return term, miss * scale, order


def fit_map(sources, length: float, tol: float):
    """The :class:`~actuator_design.model.source_fit.FittedField` of mapped coils (module docstring):
    their terms (dimensionless, per H0), H0 (A/m: the largest |H| of the fitted total over the
    reach |r| ≤ ℓ where every fit holds), the held-out error (the coils' misses added, per H0) and
    the gradient's error NaN (a map has no gradient samples)."""
    fits = []
    for s in sources:  # per ampere, then at the coil's current
        term, miss, order = _fit_coil(s, length, tol)
        fits.append((replace(term, coefficients=tuple(v * s.current for v in term.coefficients)),
                     miss * abs(s.current), order))
    grid = reach_grid()
    keep = np.all([t.contains(grid[:, 0], grid[:, 1]) for t, _, _ in fits], axis=0)
    if not keep.any():
        raise ValueError("the maps' region holds no point of the rod's reach")
    hx, hy = field_function([t for t, _, _ in fits]).map(int(keep.sum()))(grid[keep, 0], grid[keep, 1])
    h0 = float(np.max(np.hypot(np.asarray(hx, float), np.asarray(hy, float))))
    if not (h0 > 0 and math.isfinite(h0)):
        raise ValueError("the coils give no field in the rod's plane over its reach")
    terms = tuple(replace(t, coefficients=tuple(v / h0 for v in t.coefficients)) for t, _, _ in fits)
    return FittedField(terms, h0, sum(m for _, m, _ in fits) / h0, math.nan, tuple(o for _, _, o in fits))
