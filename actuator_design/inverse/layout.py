"""How every design NLP lays out its variables and constraint rows: named blocks with their bounds.

A design NLP (single pose :class:`~actuator_design.inverse.nlp.DesignNLP`, shape
:class:`~actuator_design.inverse.shape.ShapeDesignNLP`, poses × corner scenarios
:class:`~actuator_design.robust.design_robust.ScenarioDesignNLP`) stacks its unknowns (states θ,
the design vector d, lifted certificate entries, …) and its rows (equilibrium, stability pivots, tip,
profile bounds, clearance, …) in one order. :class:`Blocks` keeps that order once, by name, with each
block's default bounds, so that a solve asks for ``rows.bounds(profiles=(lo, hi))`` instead of
re-counting offsets. The states an NLP carries are poses × scenarios (:class:`DesignStates`: one
pose and the nominal scenario for the single-pose and shape NLPs), each with the same rows
(:func:`state_rows`: stationarity, reduced Hessian, tip pose, clearance); with the design vector's
map and effort (:class:`~actuator_design.inverse.design_map.DesignVector`), the certificate
(:class:`~actuator_design.inverse.ldl.Certificate`), :func:`profile_rows`, :func:`ipopt_options` and
:func:`outcome`, they are what the three assemble alike; each adds its own objective (tip, shape,
worst corner, stiffness) and IPOPT options.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, Mapping, NamedTuple, Optional, Sequence, Tuple

import casadi as ca
import numpy as np

from actuator_design.contact.clearance import clearance_rows
from actuator_design.inverse.design_map import design_params

__all__ = ["Blocks", "Variant", "StateRows", "DesignStates", "state_rows", "profile_rows", "ipopt_options", "outcome"]

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


class DesignStates:
    """Every equilibrium state a design NLP carries: poses × scenarios, each with its rows.

    Pose k's design values (its scalars and the shared profiles, read by ``dmap``) give its forward
    parameters P_k (:func:`~actuator_design.inverse.design_map.design_params`); scenario c gives
    P_kc = ``corner``(P_k, c) (c = 0: P_k itself, the nominal state; c ≥ 1: a corner of the lab's
    tolerance box); the state θ_kc (n free nodes, a new unknown) contributes :func:`state_rows`.

    Parameters
    ----------
    solver : EquilibriumSolver
    dmap : DesignVector
    d, P0 : casadi.SX
        The design vector (dmap.size,) and the base scene's parameters (n_params,).
    vandermonde : ndarray or None
        Legendre basis at the quadrature points (designed profiles).
    n_corners : int
        Scenarios besides the nominal one, per pose.
    corner : callable, optional
        ``(P (n_params,), c) -> P_c``: scenario c's parameters (needed when ``n_corners`` > 0).
    obstacles, gap
        Obstacles every state keeps ``gap`` clear of (:func:`state_rows`).

    Attributes
    ----------
    params : list of casadi.SX
        P_k per pose.
    z : list of casadi.SX, each (n,)
        θ of pose k, scenario c at index k (n_corners + 1) + c.
    rows : list of StateRows
        In the same order.
    """

    def __init__(self, solver, dmap, d: ca.SX, P0: ca.SX, vandermonde=None, n_corners: int = 0,
                 corner=None, obstacles: Sequence = (), gap: float = 0.0):
        n = solver.transcription.nodes.size - 1
        sl = solver.layout.slices
        self.params, self.z, self.rows = [], [], []
        for k in range(dmap.n_poses):
            Pk = design_params(P0, dmap.values(d, k), sl, vandermonde)
            self.params.append(Pk)
            for c in range(n_corners + 1):
                z = ca.SX.sym(f"theta_{k}_{c}", n)
                self.z.append(z)
                self.rows.append(state_rows(solver, z, Pk if c == 0 else corner(Pk, c), obstacles, gap))


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
