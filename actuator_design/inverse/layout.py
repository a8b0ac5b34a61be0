"""How every design NLP lays out its variables and constraint rows: named blocks with their bounds.

A design NLP (single pose :class:`~actuator_design.inverse.nlp.DesignNLP`, shape
:class:`~actuator_design.inverse.shape.ShapeDesignNLP`, poses × corner scenarios
:class:`~actuator_design.robust.design_robust.ScenarioDesignNLP`) stacks its unknowns (states θ,
the design vector d, lifted certificate entries, …) and its rows (equilibrium, stability pivots, tip,
profile bounds, clearance, …) in one order. :class:`Blocks` keeps that order once, by name, with each
block's default bounds, so that a solve asks for ``rows.bounds(profiles=(lo, hi))`` instead of
re-counting offsets. Each equilibrium state an NLP carries contributes the same rows
(:func:`state_rows`: stationarity, reduced Hessian, tip pose, clearance); :func:`profile_rows`,
:func:`ipopt_options` and :func:`outcome` are the other pieces the three assemble alike.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, Mapping, NamedTuple, Optional, Sequence, Tuple

import casadi as ca
import numpy as np

from actuator_design.contact.clearance import clearance_rows

__all__ = ["Blocks", "Variant", "StateRows", "state_rows", "profile_rows", "ipopt_options", "outcome"]

Bound = Tuple[object, object]


class Blocks:
    """Named blocks of one NLP vector (its variables x or its rows g), in order, with default bounds.

    Examples
    --------
    >>> rows = Blocks()
    >>> rows.add("eq", ca.SX.sym("g", 3), 0.0, 0.0)
    >>> rows.add("pivots", ca.SX.sym("q", 3), 0.0, np.inf)
    >>> lo, hi = rows.bounds()          # arrays of shape (6,)
    >>> rows["pivots"]
    slice(3, 6, None)
    """

    def __init__(self):
        self._exprs: list = []
        self._bounds: Dict[str, Tuple[np.ndarray, np.ndarray]] = {}
        self._slices: Dict[str, slice] = {}
        self.size = 0

    def add(self, name: str, expr, lo=-np.inf, hi=np.inf) -> slice:
        """Append block ``name`` (a CasADi column, possibly empty) with default bounds ``lo``, ``hi``
        (scalars or arrays of its length); returns its slice."""
        if name in self._slices:
            raise ValueError(f"block {name!r} is already laid out")
        n = int(expr.numel())
        self._slices[name] = slice(self.size, self.size + n)
        self._bounds[name] = (np.broadcast_to(np.asarray(lo, float), (n,)),
                              np.broadcast_to(np.asarray(hi, float), (n,)))
        self._exprs.append(expr)
        self.size += n
        return self._slices[name]

    def __getitem__(self, name: str) -> slice:
        return self._slices[name]

    def __contains__(self, name: str) -> bool:
        return name in self._slices

    def vector(self) -> ca.SX:
        """The blocks stacked, shape (size, 1)."""
        return ca.vertcat(*self._exprs)

    def bounds(self, **given: Bound) -> Tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds, shape (size,) each: the defaults, with the blocks named in
        ``given`` bounded by their ``(lo, hi)`` (scalars or arrays of the block's length)."""
        unknown = set(given) - set(self._slices)
        if unknown:
            raise KeyError(f"no block named {sorted(unknown)} (blocks: {', '.join(self._slices)})")
        lo, hi = np.empty(self.size), np.empty(self.size)
        for name, sl in self._slices.items():
            lo[sl], hi[sl] = given.get(name, self._bounds[name])
        return lo, hi


class Variant(NamedTuple):
    """One built variant of a design NLP (e.g. with or without the stability certificate): the
    solver, its unknowns and rows, and the certificate with the function that starts its lifted
    entries (``certificate.start(schur, ...)``), when it has one."""

    solver: object
    x: Blocks
    rows: Blocks
    certificate: Optional[object] = None
    schur: Optional[ca.Function] = None


@dataclass(frozen=True)
class StateRows:
    """What one equilibrium state θ (n free nodes) of a design NLP contributes (CasADi expressions).

    Attributes
    ----------
    energy : casadi.SX, shape (1, 1)
        The discrete energy Ê(θ; P).
    eq : casadi.SX, shape (n, 1)
        The stationarity rows ∇Ê / m (mass-scaled, THEORY §4–5).
    hessian : casadi.SX, shape (n, n)
        The reduced Hessian H_r (the stability certificate's matrix: ``certificate_matrix``).
    mass : ndarray, shape (n,)
        The lumped mass m of the free nodes.
    tip : casadi.SX, shape (3, 1)
        The tip pose (x, y, angle), in rod lengths and rad.
    clear : casadi.SX, shape (k, 1)
        Distances beyond the gap to every obstacle at the points they are imposed at (none without
        obstacles: :mod:`actuator_design.contact.clearance`).
    """

    energy: ca.SX
    eq: ca.SX
    hessian: ca.SX
    mass: np.ndarray
    tip: ca.SX
    clear: ca.SX


def state_rows(solver, z: ca.SX, P: ca.SX, obstacles: Sequence = (), gap: float = 0.0) -> StateRows:
    """The rows of the state ``z`` (θ at the free nodes, shape (n,)) of ``solver``'s transcription
    at the forward parameters ``P`` (the clamp angle read from ``P``)."""
    tr = solver.transcription
    energy, g, H = solver.f_grad_hess(z, P)
    m = tr.mass[1:]
    theta = ca.vertcat(P[solver.layout.slices["theta0"]], z)
    tip = solver.f_tip(theta, P)
    return StateRows(energy, g / ca.DM(m), H, m, ca.vertcat(tip[1], tip[2], tip[0]),
                     clearance_rows(tr, theta, obstacles, gap))


def profile_rows(vandermonde, values: Mapping[str, object], names: Sequence[str]) -> ca.SX:
    """The designed profiles at the quadrature points, one block per name in ``names`` order (α, then β):
    V c for each profile's Legendre coefficients ``values[name]``; empty without profiles."""
    return ca.vertcat(*[ca.mtimes(ca.DM(vandermonde), values[name]) for name in names])


def ipopt_options(**ipopt) -> dict:
    """IPOPT options of a design NLP: silent, with the given ``ipopt.<name>`` settings."""
    return {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes",
            **{f"ipopt.{k}": v for k, v in ipopt.items()}}


def outcome(nlp) -> Tuple[bool, str]:
    """(converged, IPOPT's return status) of the last solve of ``nlp``: solved, also to the
    acceptable level."""
    st = nlp.stats()
    status = str(st.get("return_status"))
    return bool(st.get("success", False)) or status == "Solved_To_Acceptable_Level", status
