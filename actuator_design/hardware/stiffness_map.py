"""A hardware map's equilibria with their tip stiffness and its exact derivative in the hardware
setting (issue 19 item 2: a stiffness target in real fields).

The stiffness is the ideal-field design's (:mod:`actuator_design.inverse.nlp`): the vertical tip
stiffness K = dp/dv1 = 1/c (units of B0/ℓ³; THEORY §6), with the compliance

    c = ∂y(1)/∂u · v,    H v = −∂g/∂p,

u the node angles after the clamp, g = ∇_u Ê and H its Jacobian at the equilibrium, p the vertical
tip load. Its derivative along a hardware setting w (coil weights, a magnet's pose) needs the
energy's third derivatives. They come from one scalar, by the adjoint form: with a = H⁻¹ ∂y(1)/∂u,

    Φ(u, P; v, a) = ∂y(1)/∂u · v − a · (H v + ∂g/∂p)

is stationary in v and a at the equilibrium's v and a, and equals c there; so

    dc/dw = ∂Φ/∂u · du/dw + ∂Φ/∂P · ∂P/∂w    (v, a held),

du/dw the map's implicit derivative (:meth:`~actuator_design.hardware.map.HardwareMap.state_derivative`)
and ∂Φ/∂P read at the NLP parameters w sets. :class:`StiffnessMap` gives a point whose "tip" is the
tip's targeted coordinates followed by log(c·K_target) = log(K_target/K) (0 at the target
stiffness; the logarithm keeps the SQP's steps of one size for a target near and far, and its
tolerance relative), so that the tip design's SQP (:mod:`actuator_design.hardware.current_sqp`)
meets both as it meets a tip.
"""
from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Dict, Mapping, Optional, Tuple

import casadi as ca
import numpy as np

from actuator_design.equilibrium.pipeline import solve
from actuator_design.hardware.design import VERIFY_TOL
from actuator_design.hardware.map import HardwareMap
from actuator_design.inverse.verify import stiffness_by_differences
from actuator_design.robust.tolerances import bending_scale

__all__ = ["StiffnessMap", "StiffnessFit", "verify_stiffness", "check_stiffness", "stiffness_missed",
           "stiffness_message", "ACCEPT_TOL", "AT_TARGET"]

#: the verified stiffness's relative tolerance of a success by default (the ideal-field design's accept_tol)
ACCEPT_TOL = 1e-3
#: the stiffness coordinate of a point (log(c·K_target)) at the target stiffness
AT_TARGET = 0.0


@dataclass(kw_only=True)
class StiffnessFit:
    """What a stiffness design over hardware adds to its design's result (``target`` is then the
    tip's targeted coordinates, empty for a stiffness alone; ``tip_error`` nan without them).

    Attributes
    ----------
    stiffness_target, achieved_stiffness : float
        The target and the design state's K = dp/dv1 (units of B0/ℓ³; exact, from its reduced Hessian).
    accept_tol : float
        The verified stiffness's relative tolerance of a success.
    worst_stiffness_error : float
        The largest |K/K_target − 1| over the box's corners (nan where a corner was not reached).
    """

    stiffness_target: float = math.nan
    achieved_stiffness: float = math.nan
    accept_tol: float = ACCEPT_TOL
    worst_stiffness_error: float = math.nan

    def _repr_parts(self) -> list:
        return [f"stiffness={self.achieved_stiffness:.6g}", f"stiffness_target={self.stiffness_target:.6g}"]

    def stiffness_dict(self) -> dict:
        """The ``stiffness`` key of the JSON contract."""
        return {"target": self.stiffness_target, "achieved": self.achieved_stiffness,
                "verified": self.verification.get("stiffness", math.nan), "accept_tol": self.accept_tol,
                "worst_error_over_box": self.worst_stiffness_error, "units": "B0/l^3"}

    def record_box_stiffness(self) -> None:
        """The worst relative stiffness error over the recorded box (nan where a corner was not reached)."""
        errors = [c["stiffness_error"] for c in self.box]
        self.worst_stiffness_error = max(errors, default=math.nan) if all(math.isfinite(e) for e in errors) \
            else math.nan


def _real(value) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def check_stiffness(stiffness, target, accept_tol: float) -> np.ndarray:
    """The tip's targeted coordinates as an array (0, 2 or 3); ValueError for a stiffness that is
    not a finite number > 0, a target that is not x, y[, angle] or an ``accept_tol`` that is not a
    finite number below 1."""
    if not (_real(stiffness) and math.isfinite(stiffness) and stiffness > 0):
        raise ValueError(f"stiffness target: must be a finite number > 0 (units of B0/l^3), got {stiffness!r}")
    # (as the design settings: below 1, and <= 0 accepts nothing, a way to see the verdicts)
    if not (_real(accept_tol) and math.isfinite(accept_tol) and accept_tol < 1):
        raise ValueError(f"stiffness design: accept_tol must be a finite number < 1, got {accept_tol!r}")
    tip = np.zeros(0) if target is None else np.asarray(target, float)
    if tip.size not in (0, 2, 3) or not np.all(np.isfinite(tip)):
        raise ValueError(f"design: the target is x, y[, angle] (finite numbers), got {tip.tolist()}")
    return tip


class StiffnessMap:
    """The points of ``hmap`` with the tip stiffness as one more coordinate.

    Parameters
    ----------
    hmap : HardwareMap
        Its scene must hold a vertical tip load term (the NLP parameter ``fy``; zero load is fine).
    stiffness : float
        The target K (units of B0/ℓ³), > 0.
    tip_coords : int
        How many of the tip's coordinates (x, y, angle) are targeted too: 0, 2 or 3.
    """

    def __init__(self, hmap: HardwareMap, stiffness: float, tip_coords: int):
        self.hmap, self.k_target, self.m = hmap, float(stiffness), int(tip_coords)
        self._cache: Dict[tuple, Optional[dict]] = {}
        solver = hmap.solver
        zr, P, _, gr = solver.reduced_energy
        lay = solver.layout
        if "fy" not in lay.slices:
            raise ValueError("a stiffness target needs a tip-force term in the scene")
        n = zr.numel()
        y = solver.f_tip(ca.vertcat(P[lay.slices["theta0"]], zr), P)[2]
        dy = ca.gradient(y, zr)
        seed = np.zeros(lay.size)
        seed[lay.slices["fy"].start] = 1.0
        dg_dp = ca.jtimes(gr, P, ca.DM(seed))
        v, a = ca.SX.sym("v", n), ca.SX.sym("a", n)
        phi = ca.dot(dy, v) - ca.dot(a, ca.jtimes(gr, zr, v) + dg_dp)
        self._rhs = ca.Function("compliance_rhs", [zr, P], [ca.densify(dg_dp), ca.densify(dy)])
        self._dphi = ca.Function("compliance_derivative", [zr, P, v, a],
                                 [ca.densify(ca.gradient(phi, zr)), ca.densify(ca.gradient(phi, P))])
        self._slots = [lay.slices[name].start for name in hmap.names]

    @property
    def solves(self) -> int:
        """The map's solves (so that the hardware designs' runs count them here too)."""
        return self.hmap.solves

    @solves.setter
    def solves(self, value: int) -> None:
        self.hmap.solves = value

    def compliance(self, z: np.ndarray, P: np.ndarray, derivative_of: Optional[np.ndarray] = None
                   ) -> Tuple[float, Optional[np.ndarray]]:
        """(c, dc/dw) at the equilibrium ``z`` (node angles, rad) of the NLP parameters ``P``; the
        derivative only when ``derivative_of`` gives the setting w. c is nan where H is singular."""
        ker = self.hmap.solver.kernel
        ker.set_params(P)
        ker.evaluate(z[1:])
        H = ker.hessian_dense()
        dg_dp, dy = (np.asarray(q, float).ravel() for q in self._rhs(z[1:], P))
        try:
            v = -np.linalg.solve(H, dg_dp)
            a = np.linalg.solve(H, dy)
        except np.linalg.LinAlgError:
            return math.nan, None
        c = float(dy @ v)
        if derivative_of is None:
            return c, None
        w = np.asarray(derivative_of, float)
        du, dP = (np.asarray(q, float).ravel() for q in self._dphi(z[1:], P, v, a))
        return c, du @ self.hmap.state_derivative(z, w) + dP[self._slots]

    def corner_stiffness(self, corner: dict, deltas: Mapping[str, float]) -> dict:
        """A box corner's (:meth:`~actuator_design.hardware.map.HardwareMap.corner`) ``stiffness`` K
        (units of the nominal B0/ℓ³: a corner whose E is moved by ``deltas`` is solved in its own
        units, :func:`~actuator_design.robust.tolerances.bending_scale`; nan where it was not
        reached or sits at a fold) and ``stiffness_error`` |K/K_target − 1|."""
        c = self.compliance(corner["z"], corner["params"])[0] if "z" in corner else math.nan
        k = (1.0 / c if c != 0.0 else math.inf) * bending_scale(deltas)
        return {"stiffness": k, "stiffness_error": abs(k / self.k_target - 1.0)}

    def evaluate(self, w: np.ndarray) -> Optional[dict]:
        """The map's point at ``w`` with ``tip`` = (the targeted tip coordinates, log(c·K_target))
        and ``tip_jac`` its derivative in w; ``tip_point`` the rod's tip (x, y, angle),
        ``stiffness`` K. None where the map has no point (or no finite positive compliance: a fold).
        Cached by w."""
        key = tuple(np.asarray(w, float).tolist())
        if key not in self._cache:
            pt = self.hmap.evaluate(w)
            if pt is not None:
                P = self.hmap.solver.parameter_vector(self.hmap.at(self.hmap.scene, np.asarray(w, float)))
                c, dc = self.compliance(pt["z"], P, derivative_of=w)
                if dc is None or not (math.isfinite(c) and c > 0.0):  # (stable: c = ∂y·H⁻¹∂y > 0)
                    pt = None
                else:
                    pt = {**pt, "tip_point": pt["tip"], "stiffness": 1.0 / c,
                          "tip": np.concatenate([pt["tip"][:self.m], [math.log(c * self.k_target)]]),
                          "tip_jac": np.vstack([pt["tip_jac"][:self.m], dc[None, :] / c])}
            self._cache[key] = pt
        return self._cache[key]

    def miss(self, w: np.ndarray, station: dict) -> float:
        """How far a station of a ramp (``z``) is from the stiffness: |log(c·K_target)| (the
        screen's ranking of a stiffness alone)."""
        P = self.hmap.solver.parameter_vector(self.hmap.at(self.hmap.scene, np.asarray(w, float)))
        c, _ = self.compliance(station["z"], P)
        return abs(math.log(c * self.k_target)) if math.isfinite(c) and c > 0.0 else math.inf


def verify_stiffness(out, refitted, options, target_tip: np.ndarray, accept_tol: float) -> None:
    """Solve ``refitted`` (magpylib's field fitted anew at the answer) from rest: its tip must meet
    ``target_tip`` (the targeted coordinates; with none, the design's own tip) to
    :data:`~actuator_design.hardware.design.VERIFY_TOL`, the state be stable, and its stiffness by
    central differences of two independent solves (:func:`~actuator_design.inverse.verify.stiffness_by_differences`)
    be within ``accept_tol`` (relative) of ``out.stiffness_target``. Recorded in ``out``."""
    r = solve(refitted, options)
    vt = np.array([r.tip["x"], r.tip["y"], r.tip["angle"]])
    ref = target_tip if target_tip.size else np.asarray(out.tip, float)[:2]
    err = float(np.max(np.abs(vt[:ref.size] - ref)))
    k = stiffness_by_differences(refitted, options, r) if r.success else math.nan
    rel = abs(k / out.stiffness_target - 1.0) if math.isfinite(k) else math.nan
    out.verification = {"tip": {"x": vt[0], "y": vt[1], "angle": vt[2]}, "error": err, "success": bool(r.success),
                        "stable": bool(r.stable), "status": r.status, "stiffness": k, "stiffness_error": rel}
    out.verified = bool(r.success and r.stable and err <= VERIFY_TOL and rel <= accept_tol)


def stiffness_missed(out, sqp, what: str, extra: str = "") -> None:
    """The search ended off the target: the nearest stiffness (and tip) found, with the limits that
    bind; ``what`` names the hardware (\"setting of the currents within the limits\"), ``extra``
    is added to the message."""
    binds = f" ({', '.join(out.limits_active)} at the limit)" if out.limits_active else ""
    near = (f"stiffness {out.achieved_stiffness:.6g} B0/l^3 against the target {out.stiffness_target:.6g}"
            + (f", tip {out.tip_error:.3g} rod lengths off" if out.target else ""))
    if sqp.stopped_short:
        out.status = "not_converged"
        out.message = (f"the search stopped short ({near}) in a thin band of reachable states with no limit "
                       f"binding: the target may be reachable by a {what}, but none was found" + extra)
    else:
        out.status = "unreachable"
        out.message = (f"no {what} gives the "
                       f"{'stiffness with the tip on the target' if out.target else 'stiffness'}: the nearest found "
                       f"(a local search, not certified the nearest) has {near}{binds}" + extra)


def stiffness_message(out, setting: str) -> str:
    """The closing message: ``setting`` (the currents, the pose) gives the stiffness, the verdicts."""
    text = f"{setting} give{'s' * setting.startswith('the magnet')} the tip stiffness {out.achieved_stiffness:.6g} B0/l^3"
    if out.target:
        text += f" with the tip on the target (miss {out.tip_error:.2g} rod lengths)"
    v = out.verification
    if not v:
        return text + "; not verified (verification off)"
    if not out.verified:
        return text + (f"; NOT verified: the refitted field solved from rest gives a tip {v['error']:.3g} rod lengths "
                       f"off and the stiffness {v['stiffness']:.6g} (relative error {v['stiffness_error']:.3g}, "
                       f"accepted {out.accept_tol:g}; {v['status']}, stable {v['stable']})")
    text += f"; the refitted field's stiffness by differences is {v['stiffness']:.6g}"
    if not out.holds_over_box:
        return text + out.not_robust()
    return text + (f"; over the box ({len(out.box)} corners) the stiffness is off by at most "
                   f"{out.worst_stiffness_error:.3g} relative"
                   + (f" and the tip by {out.worst_tip_error:.3g} rod lengths" if out.target else ""))
