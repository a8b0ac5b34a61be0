"""The forward map of a design over coil currents: currents → the equilibrium, its tip and the field
the rod sees, with exact derivatives (issue 19 item 2).

A coil scene's field is ĥ = Σ_k w_k ĥ_k (``SourceField.weights``): coil k's fitted field scaled by
w_k = I_k / I_k⁰, its current over the current it was fitted at. The weights are NLP parameters, so
one built solver serves every current vector. :class:`CurrentMap` gives, at every w, the state
reached from rest — every current ramped together from zero, as a lab switches its drivers on
(:func:`~actuator_design.from_rest.path_from_rest` on the start state's mesh: the map is single
valued, and where that ramp snaps it jumps) — and differentiates it by the implicit-function
theorem on the reduced system (THEORY §7: g(u; w) = 0 at an equilibrium):

    du/dw = −H⁻¹ ∂g/∂w,    d tip/dw = ∂tip/∂u · du/dw,

and the squared field at the rod's quadrature points, |ĥ(r_q(u); w)|², the same way (its direct
dependence on w plus the move of the points).
"""
from __future__ import annotations

from dataclasses import replace
from typing import Dict, List, Optional, Tuple

import casadi as ca
import numpy as np

from ..equilibrium import solve
from ..from_rest import path_from_rest
from ..physics.fields import field_model
from ..result import EquilibriumResult
from ..scene import Scene
from ..solver import get_solver

__all__ = ["CurrentMap", "at_weights"]



def at_weights(scene: Scene, w) -> Scene:
    """``scene`` with its coils' field weights set to ``w`` (n,)."""
    return replace(scene, field=replace(scene.field, weights=tuple(float(v) for v in w)))


class CurrentMap:
    """Equilibria of a coil scene as functions of the weights w, on one mesh.

    Parameters
    ----------
    scene : Scene
        A scene whose field is a ``SourceField`` of coils.
    start : EquilibriumResult
        The state reached from rest at ``w_start`` (its mesh is the map's mesh, its options the
        map's, solved by Newton).
    w_start : ndarray, shape (n,)

    Attributes
    ----------
    solves : int
        Warm-started solves so far.
    """

    def __init__(self, scene: Scene, start: EquilibriumResult, w_start: np.ndarray):
        self.scene = scene
        # Newton from the neighbouring state: ~10x faster here than IPOPT, whose Hessian in a
        # fitted field is quasi-Newton; each state's stability is checked all the same
        self.options = replace(start.options, method="newton")
        self.n = len(scene.field.terms)
        self.solver = get_solver(at_weights(scene, w_start), self.options)
        self.solves = 0
        self._cache: Dict[tuple, Optional[dict]] = {}
        self._g_w, self._tip_z, self._points, self._point_field = self._functions()

    # -- states -----------------------------------------------------------------------------------
    def state(self, w: np.ndarray) -> Optional[np.ndarray]:
        """The node angles z reached from rest at ``w`` (every current ramped together from zero,
        :func:`~actuator_design.from_rest.path_from_rest` on the map's mesh), or None where that
        path fails or ends on a state that is not stable."""
        P = self.solver.parameter_vector(at_weights(self.scene, w))
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
        reached, with ``h2`` the squared field at the quadrature points."""
        P = self.solver.parameter_vector(at_weights(self.scene, w_end))
        stations = [(float(t), self.solver.parameter_vector(at_weights(self.scene, t * w_end))) for t in fractions]
        path = path_from_rest(self.solver, P, stations=stations)
        self.solves += path.solves
        out = []
        for (t, Pt), visit in zip(stations, path.visits):
            z = np.asarray(visit.z, float)
            tip_theta, tip_x, tip_y = (float(v) for v in self.solver.f_tip(z, Pt))
            x, y, _, _ = (np.asarray(v, float) for v in self._points(z))
            h2 = np.asarray(self._point_field(x.T, y.T, t * w_end)[0], float).ravel()
            out.append((t * w_end, {"z": z, "tip": np.array([tip_x, tip_y, tip_theta]), "h2": h2}))
        return out

    def evaluate(self, w: np.ndarray) -> Optional[dict]:
        """At ``w``: ``z`` the state from rest, ``tip`` (x, y, angle) (3,), ``tip_jac`` d tip/dw
        (3, n), ``h2`` the squared field |ĥ|² at the quadrature points (q,) and ``h2_jac`` (q, n);
        None where :meth:`state` fails. Cached by w."""
        key = tuple(np.asarray(w, float).tolist())
        if key not in self._cache:
            z = self.state(np.asarray(w, float))
            self._cache[key] = None if z is None else self._derivatives(z, np.asarray(w, float))
        return self._cache[key]

    def corner(self, scene: Scene, z_design: np.ndarray) -> dict:
        """A perturbed scene (same structure: other weights, E, clamp angle) seen two ways: the
        state reached from rest there, and the design state followed to it by one warm solve.
        Returns ``tip`` (3,) of the state from rest (nan if none), ``reached``, ``stable`` and
        ``same_branch`` (the two states agree to 1e-6 rad: switching on at the corner lands on the
        designed branch)."""
        P = self.solver.parameter_vector(scene)
        path = path_from_rest(self.solver, P)
        self.solves += path.solves + 1
        if not path.reached:
            return {"tip": np.full(3, np.nan), "reached": False, "stable": False, "same_branch": False}
        z = np.asarray(path.z, float)
        tip_theta, tip_x, tip_y = (float(v) for v in self.solver.f_tip(z, P))
        followed = solve(scene, self.options, initial=np.asarray(z_design, float), solver=self.solver)
        same = bool(followed.success and float(np.max(np.abs(np.asarray(followed.z) - z))) <= 1e-6)
        return {"tip": np.array([tip_x, tip_y, tip_theta]), "reached": True,
                "stable": bool(self.solver.stability(z, P).stable), "same_branch": same}

    def result(self, w: np.ndarray, z: np.ndarray) -> EquilibriumResult:
        """The equilibrium result at ``w`` from its state ``z`` (one polishing solve on the map's
        mesh, with its stability verdict and diagnostics)."""
        return solve(at_weights(self.scene, w), self.options, initial=z, solver=self.solver)

    def _state_derivative(self, z: np.ndarray, w: np.ndarray) -> np.ndarray:
        """du/dw = −H⁻¹ ∂g/∂w at the equilibrium z, shape (n_u, n)."""
        P = self.solver.parameter_vector(at_weights(self.scene, w))
        ker = self.solver.kernel
        ker.set_params(P)
        ker.evaluate(z[1:])
        return -np.linalg.solve(ker.hessian_dense(), np.asarray(self._g_w(z[1:], P), float))

    def _derivatives(self, z: np.ndarray, w: np.ndarray) -> dict:
        P = self.solver.parameter_vector(at_weights(self.scene, w))
        du = self._state_derivative(z, w)
        tip_theta, tip_x, tip_y = (float(v) for v in self.solver.f_tip(z, P))
        tip_jac = np.asarray(self._tip_z(z, P), float)[:, 1:] @ du  # rows x, y, θ
        x, y, jx, jy = (np.asarray(v, float) for v in self._points(z))
        q = x.size
        h2, h2x, h2y, h2w = (np.asarray(v, float) for v in self._point_field(x.T, y.T, w))
        h2_z = h2x.reshape(q, 1) * jx + h2y.reshape(q, 1) * jy  # the points move: ∂|ĥ|²/∂r · ∂r/∂z
        return {"z": z, "tip": np.array([tip_x, tip_y, tip_theta]), "tip_jac": tip_jac,
                "h2": h2.ravel(), "h2_jac": h2w.reshape(q, self.n) + h2_z[:, 1:] @ du}

    def _functions(self):
        """CasADi functions: ∂g/∂w (forward derivatives of the solver's gradient along the weight
        slots), ∂tip/∂z, the quadrature points and their Jacobians, and the squared field at a
        point with its derivatives (mapped over the points)."""
        solver = self.solver
        z, zr, P, _, _, gr = solver._sym
        lay = solver.layout
        seeds = np.zeros((lay.size, self.n))
        for k in range(self.n):
            seeds[lay.slices[f"source_weight_{k}"].start, k] = 1.0
        g_w = ca.Function("g_w", [zr, P], [ca.densify(ca.jtimes(gr, P, ca.DM(seeds)))])
        tip_theta, tip_x, tip_y = solver.f_tip(z, P)
        tip = ca.vertcat(tip_x, tip_y, tip_theta)
        tip_z = ca.Function("tip_z", [z, P], [ca.densify(ca.jacobian(tip, z))])
        tr = solver.transcription
        theta_q, _ = tr.point_values(z)
        xq, yq = tr.point_positions(theta_q)
        points = ca.Function("points", [z], [xq, yq, ca.densify(ca.jacobian(xq, z)), ca.densify(ca.jacobian(yq, z))])
        xs, ys, w = ca.SX.sym("x"), ca.SX.sym("y"), ca.SX.sym("w", self.n)
        model = field_model(self.scene.field)
        hx, hy = model.value(xs, ys, {name: w[k] for k, name in enumerate(model.params)})
        h2 = hx * hx + hy * hy
        one = ca.Function("h2", [xs, ys, w], [h2, ca.jacobian(h2, xs), ca.jacobian(h2, ys), ca.jacobian(h2, w)])
        q = tr.quadrature_points.size
        return g_w, tip_z, points, one.map(q)
