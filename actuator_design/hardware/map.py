"""The forward map of a design over hardware — coil currents, a magnet's pose — to the equilibrium,
its tip and a pointwise quantity along the rod, with exact derivatives (issue 19 item 2).

The hardware enters the NLP as parameters of the scene's field (``SourceField.weights``: a coil's
current over the current it was fitted at; ``SourceField.placements``: a source's rigid move), so
one built solver serves every setting v. :class:`HardwareMap` gives, at every v, the state reached
from rest — the field switched on from zero as a lab does
(:func:`~actuator_design.continuation.from_rest.path_from_rest` on the start state's mesh: the map is single
valued, and where that ramp snaps it jumps) — and differentiates it by the implicit-function
theorem on the reduced system (THEORY §7: g(u; v) = 0 at an equilibrium):

    du/dv = −H⁻¹ ∂g/∂v,    d tip/dv = ∂tip/∂u · du/dv,

and a quantity c(r_q; v) at the rod's quadrature points (the squared field for currents, the
clearance from a magnet for a pose) the same way: its direct dependence on v plus the move of the
points.
"""
from __future__ import annotations

from dataclasses import replace
from typing import Callable, Dict, List, Optional, Sequence, Tuple

import casadi as ca
import numpy as np

from actuator_design.continuation.from_rest import path_from_rest
from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.result import EquilibriumResult
from actuator_design.equilibrium.solver import get_solver
from actuator_design.model.scene import Scene

__all__ = ["HardwareMap"]


class HardwareMap:
    """Equilibria of a source-field scene as functions of hardware settings v, on one mesh.

    Parameters
    ----------
    scene : Scene
        A scene whose field is a ``SourceField``.
    start : EquilibriumResult
        The state reached from rest at ``v_start`` (its mesh is the map's mesh, its options the
        map's, solved by Newton).
    v_start : ndarray, shape (n,)
    names : sequence of str
        The NLP parameters v sets, in order (n).
    at : callable
        ``at(scene, v)``: the scene at the setting v.
    pointwise : callable
        ``pointwise(x, y, v)`` of CasADi scalars x, y (units of ℓ) and v (n,) → the quantity at one
        point (SX, shape (s, 1)); :meth:`evaluate` gives it at every quadrature point.

    Attributes
    ----------
    solves : int
        Warm-started solves so far.
    """

    def __init__(self, scene: Scene, start: EquilibriumResult, v_start: np.ndarray, names: Sequence[str],
                 at: Callable[[Scene, np.ndarray], Scene], pointwise: Callable):
        self.scene, self.names, self.at, self.pointwise = scene, tuple(names), at, pointwise
        # Newton from the neighbouring state: ~10x faster here than IPOPT, whose Hessian in a
        # fitted field is quasi-Newton; each state's stability is checked all the same
        self.options = replace(start.options, method="newton")
        self.n = len(self.names)
        self.solver = get_solver(at(scene, np.asarray(v_start, float)), self.options)
        self.solves = 0
        self._cache: Dict[tuple, Optional[dict]] = {}
        self._g_w, self._tip_z, self._points, self._point_field = self._functions()

    # -- states -----------------------------------------------------------------------------------
    def state(self, w: np.ndarray) -> Optional[np.ndarray]:
        """The node angles z reached from rest at setting ``w`` (the field switched on from zero,
        :func:`~actuator_design.continuation.from_rest.path_from_rest` on the map's mesh), or None where that
        path fails or ends on a state that is not stable."""
        P = self.solver.parameter_vector(self.at(self.scene, w))
        path = path_from_rest(self.solver, P)
        self.solves += path.solves
        if not path.reached:
            return None
        if not self.solver.stability(path.z, P).stable:
            return None
        return np.asarray(path.z, float)

    def ray(self, w_end: np.ndarray, fractions) -> List[Tuple[np.ndarray, dict]]:
        """The states from rest at t·``w_end`` for each t of ``fractions`` (ascending, ending at 1),
        from one walk of the ramp: [(w, point without derivatives: ``z``, ``tip``)] for the stations
        reached, with ``limit`` the pointwise quantity at the quadrature points."""
        P = self.solver.parameter_vector(self.at(self.scene, w_end))
        stations = [(float(t), self.solver.parameter_vector(self.at(self.scene, t * w_end))) for t in fractions]
        path = path_from_rest(self.solver, P, stations=stations)
        self.solves += path.solves
        out = []
        for (t, Pt), visit in zip(stations, path.visits):
            z = np.asarray(visit.z, float)
            tip_theta, tip_x, tip_y = (float(v) for v in self.solver.f_tip(z, Pt))
            x, y, _, _ = (np.asarray(v, float) for v in self._points(z))
            c = np.asarray(self._point_field(x.T, y.T, t * w_end)[0], float).T.ravel()
            out.append((t * w_end, {"z": z, "tip": np.array([tip_x, tip_y, tip_theta]), "limit": c}))
        return out

    def evaluate(self, w: np.ndarray) -> Optional[dict]:
        """At ``w``: ``z`` the state from rest, ``tip`` (x, y, angle) (3,), ``tip_jac`` d tip/dw
        (3, n), ``limit`` the pointwise quantity at the quadrature points (q s,) and ``limit_jac``
        (q s, n); None where :meth:`state` fails. Cached by w."""
        key = tuple(np.asarray(w, float).tolist())
        if key not in self._cache:
            z = self.state(np.asarray(w, float))
            self._cache[key] = None if z is None else self._derivatives(z, np.asarray(w, float))
        return self._cache[key]

    def corner(self, scene: Scene, z_design: np.ndarray) -> dict:
        """A perturbed scene (same structure: other weights, E, clamp angle) seen two ways: the
        state reached from rest there, and the design state followed to it by one warm solve.
        Returns ``tip`` (3,) of the state from rest (nan if none), ``reached`` (a state from rest
        that keeps to where every source's fit holds, at the rod's quadrature points — else
        ``region`` says why), ``stable`` and ``same_branch`` (the two states agree to 1e-6 rad:
        switching on at the corner lands on the designed branch), and ``z`` the state from rest
        (node angles, rad) and ``params`` the scene's NLP parameters where it was reached."""
        P = self.solver.parameter_vector(scene)
        path = path_from_rest(self.solver, P)
        self.solves += path.solves + 1
        if not path.reached:
            return {"tip": np.full(3, np.nan), "reached": False, "stable": False, "same_branch": False}
        z = np.asarray(path.z, float)
        tip_theta, tip_x, tip_y = (float(v) for v in self.solver.f_tip(z, P))
        x, y, _, _ = (np.asarray(v, float).ravel() for v in self._points(z))
        region = scene.field.region_problem(x, y) if hasattr(scene.field, "region_problem") else None
        if region is not None:
            return {"tip": np.array([tip_x, tip_y, tip_theta]), "reached": False, "stable": False,
                    "same_branch": False, "region": region}
        followed = solve(scene, self.options, initial=np.asarray(z_design, float), solver=self.solver)
        same = bool(followed.success and float(np.max(np.abs(np.asarray(followed.z) - z))) <= 1e-6)
        return {"tip": np.array([tip_x, tip_y, tip_theta]), "reached": True,
                "stable": bool(self.solver.stability(z, P).stable), "same_branch": same, "z": z, "params": P}

    def result(self, w: np.ndarray, z: np.ndarray) -> EquilibriumResult:
        """The equilibrium result at ``w`` from its state ``z`` (one polishing solve on the map's
        mesh, with its stability verdict and diagnostics)."""
        return solve(self.at(self.scene, w), self.options, initial=z, solver=self.solver)

    def state_derivative(self, z: np.ndarray, w: np.ndarray) -> np.ndarray:
        """du/dw = −H⁻¹ ∂g/∂w at the equilibrium z (node angles, the clamp's included) at the
        setting w: shape (n_u, n), u the node angles after the clamp's."""
        P = self.solver.parameter_vector(self.at(self.scene, w))
        ker = self.solver.kernel
        ker.set_params(P)
        ker.evaluate(z[1:])
        return -np.linalg.solve(ker.hessian_dense(), np.asarray(self._g_w(z[1:], P), float))

    def _derivatives(self, z: np.ndarray, w: np.ndarray) -> dict:
        P = self.solver.parameter_vector(self.at(self.scene, w))
        du = self.state_derivative(z, w)
        tip_theta, tip_x, tip_y = (float(v) for v in self.solver.f_tip(z, P))
        tip_jac = np.asarray(self._tip_z(z, P), float)[:, 1:] @ du  # rows x, y, θ
        x, y, jx, jy = (np.asarray(v, float) for v in self._points(z))
        q = x.size
        c, cx, cy, cw = (np.asarray(v, float) for v in self._point_field(x.T, y.T, w))
        s = c.size // q  # values per point; the mapped outputs are (s, q), (s, q), (s, q), (s, q n)
        c_z = (cx.T.reshape(q, s, 1) * jx.reshape(q, 1, -1) + cy.T.reshape(q, s, 1) * jy.reshape(q, 1, -1))
        c_w = cw.reshape(s, q, self.n).transpose(1, 0, 2)  # the points move: ∂c/∂r · ∂r/∂z, plus ∂c/∂v
        jac = (c_w + c_z[:, :, 1:] @ du).reshape(q * s, self.n)
        return {"z": z, "tip": np.array([tip_x, tip_y, tip_theta]), "tip_jac": tip_jac,
                "limit": c.T.ravel(), "limit_jac": jac}

    def _functions(self):
        """CasADi functions: ∂g/∂v (forward derivatives of the solver's gradient along the varied
        slots), ∂tip/∂z, the quadrature points and their Jacobians, and the pointwise quantity at a
        point with its derivatives (mapped over the points)."""
        solver = self.solver
        zr, P, _, gr = solver.reduced_energy
        z = solver.discrete.z
        lay = solver.layout
        seeds = np.zeros((lay.size, self.n))
        for k in range(self.n):
            seeds[lay.slices[self.names[k]].start, k] = 1.0
        g_w = ca.Function("g_w", [zr, P], [ca.densify(ca.jtimes(gr, P, ca.DM(seeds)))])
        tip_theta, tip_x, tip_y = solver.f_tip(z, P)
        tip = ca.vertcat(tip_x, tip_y, tip_theta)
        tip_z = ca.Function("tip_z", [z, P], [ca.densify(ca.jacobian(tip, z))])
        tr = solver.transcription
        theta_q, _ = tr.point_values(z)
        xq, yq = tr.point_positions(theta_q)
        points = ca.Function("points", [z], [xq, yq, ca.densify(ca.jacobian(xq, z)), ca.densify(ca.jacobian(yq, z))])
        xs, ys, w = ca.SX.sym("x"), ca.SX.sym("y"), ca.SX.sym("w", self.n)
        c = self.pointwise(xs, ys, w)
        one = ca.Function("pointwise", [xs, ys, w], [c, ca.jacobian(c, xs), ca.jacobian(c, ys), ca.jacobian(c, w)])
        q = tr.quadrature_points.size
        return g_w, tip_z, points, one.map(q)
