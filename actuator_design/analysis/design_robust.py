"""Robust design: one design that reaches the target and stays put over the lab's tolerance box.

The nominal design NLP (:mod:`.design_nlp`) minimises effort, which drives a design onto the fold
where its branch ends: there, 0.2 % less field and the rod snaps. Here the design is posed over
the box instead (a multi-scenario NLP, the corners of the box as scenarios):

    min_{d, θ_0..θ_C, t}  t + w · effort(d)
    s.t.  ∇Ê(θ_c; P_c(d)) = 0                     every scenario c = 0 (nominal), 1..C (corners)
          LDLᵀ pivots of M^-½ H(θ_c) M^-½ − μ I ≥ 0   every scenario (stable, margin μ)
          tip(θ_0) = target                         the nominal design reaches the target exactly
          |tip(θ_c) − target|² ≤ t                   worst-case tip error over the corners

Why this formulation: the worst-case tip error over the corners is the quantity a user builds on,
and requiring every corner to be a stable equilibrium pushes every fold out of the box (a fold
inside the box would leave a corner without its stable state). It is solved by homotopy in the box
size (¼, ½, 1 of the tolerances), each stage warm-started from the last, so the largest box a
design holds is known when the full box fails. Whether the corners' states lie on the nominal
state's branch is not part of the NLP: :func:`.robustness.evaluate_robustness` checks it afterwards
by following the branch along rays and edges.

P_c(d) maps the design vector d = (h, φ, α coefficients, p) and the corner's offsets (NLP
parameters, so the box can change without a rebuild) to the forward NLP's parameter vector, with
the scalings of :mod:`.tolerances`: h × k_h, loads × k_p, φ, α and θ0 shifted.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence

import casadi as ca
import numpy as np

from ..options import SolverOptions
from ..scene import Scene
from .design_nlp import DesignNLP, _bandwidth, _ldl_pivots
from .tolerances import Tolerances

__all__ = ["RobustDesignNLP", "RobustPoint"]

_LOADS = ("fx", "fy", "m_tip", "qx", "qy")


@dataclass
class RobustPoint:
    """One solve of the robust NLP: the design vector, the scenario states and its worst error."""

    d: np.ndarray
    z: List[np.ndarray]  # θ at all nodes, nominal first, then the corners
    worst_error: float  # max over corners of |tip − target| (units of ℓ), from the NLP's states
    converged: bool
    status: str
    scale: float  # fraction of the tolerances this solve used


def _corner_offsets(tol: Tolerances, scale: float) -> List[Dict[str, float]]:
    """Per corner: k_h (factor on h), k_p (factor on loads), dphi, dalpha, dtheta0."""
    out = []
    for c in tol.corners():
        g = {a: c.get(a, 0.0) * getattr(tol, a) * scale for a in
             ("field_rel", "angle", "youngs_rel", "chi_rel", "fibre_angle", "clamp_angle")}
        out.append({"k_h": (1 + g["field_rel"]) * math.sqrt((1 + g["chi_rel"]) / (1 + g["youngs_rel"])),
                    "k_p": 1.0 / (1 + g["youngs_rel"]), "dphi": g["angle"], "dalpha": g["fibre_angle"],
                    "dtheta0": g["clamp_angle"]})
    return out


class RobustDesignNLP:
    """The multi-scenario design NLP for one design NLP (structure, variables) and C corners.

    Parameters
    ----------
    base : DesignNLP
        The nominal design NLP: its forward solver, design variables and Legendre basis are reused.
    n_corners : int
        Number of corner scenarios (2^k for k active tolerances).
    """

    def __init__(self, base: DesignNLP, n_corners: int):
        t0 = time.perf_counter()
        self.base = base
        sv, lay = base.solver, base.solver.layout
        n, nd, C = base.n, base.nd, n_corners
        self.n, self.nd, self.C = n, nd, C
        d = ca.SX.sym("d", nd)
        P0 = ca.SX.sym("P0", lay.size)
        P = ca.SX(P0)
        sl = lay.slices
        if "h" in base.vary:
            P[sl["h"]] = d[base.dslices["h"]]
        if "phi" in base.vary:
            P[sl["phi"]] = d[base.dslices["phi"]]
        if "p" in base.vary:
            P[sl["fy"]] = d[base.dslices["p"]]
        if "alpha" in base.vary:
            P[sl["alpha"]] = ca.mtimes(ca.DM(base.vandermonde), d[base.dslices["alpha"]])
        offs = ca.SX.sym("offsets", 5 * C)  # per corner: k_h, k_p, dphi, dalpha, dtheta0
        z = [ca.SX.sym(f"theta_{c}", n) for c in range(C + 1)]
        t = ca.SX.sym("t")
        target, w_ang = ca.SX.sym("target", 3), ca.SX.sym("w_ang")
        margin, w_eff = ca.SX.sym("margin"), ca.SX.sym("w_eff")
        m = base.solver.transcription.mass[1:]
        Ms = ca.DM(1.0 / np.sqrt(m))
        bw = _bandwidth(sv, n)

        def scenario(c):
            if c == 0:
                return P
            k_h, k_p, dphi, dal, dth = (offs[5 * (c - 1) + i] for i in range(5))
            Pc = ca.SX(P)
            for name in ("h", "h_pos"):
                if name in sl:
                    Pc[sl[name]] = P[sl[name]] * k_h
            for name in _LOADS:
                if name in sl:
                    Pc[sl[name]] = P[sl[name]] * k_p
            if "phi" in sl:
                Pc[sl["phi"]] = P[sl["phi"]] + dphi
            if "alpha" in sl:
                Pc[sl["alpha"]] = P[sl["alpha"]] + dal
            Pc[sl["theta0"]] = P[sl["theta0"]] + dth
            return Pc

        eq, piv, tips, err_rows = [], [], [], []
        for c in range(C + 1):
            Pc = scenario(c)
            _, g, H = sv.f_grad_hess(z[c], Pc)
            eq.append(g / ca.DM(m))
            A = ca.diag(Ms) @ H @ ca.diag(Ms) - margin * ca.SX.eye(n)
            piv.append(ca.vertcat(*_ldl_pivots(A, bw)))
            th0 = Pc[sl["theta0"]]
            tip_fn = sv.f_tip(ca.vertcat(th0, z[c]), Pc)
            tip = ca.vertcat(tip_fn[1], tip_fn[2], tip_fn[0])
            tips.append(tip)
            if c > 0:
                e = tip - target
                err_rows.append(e[0] ** 2 + e[1] ** 2 + w_ang * e[2] ** 2 - t)
        effort = 0
        if "h" in base.vary:
            effort += d[base.dslices["h"]] ** 2
        if "p" in base.vary:
            effort += d[base.dslices["p"]] ** 2
        if "alpha" in base.vary:
            cc = d[base.dslices["alpha"]]
            k = np.arange(base.alpha_terms, dtype=float)
            effort += ca.dot(ca.DM(k**2 * (k + 1) ** 2 / 4.0), cc**2)
        alpha_rows = ([ca.mtimes(ca.DM(base.vandermonde), d[base.dslices["alpha"]])]
                      if "alpha" in base.vary else [])
        nom_err = tips[0] - target
        x = ca.vertcat(*z, d, t)
        p = ca.vertcat(P0, offs, target, w_ang, margin, w_eff)
        self._sizes = dict(eq=(C + 1) * n, piv=(C + 1) * n, nom=3, err=C,
                           alpha=base.vandermonde.shape[0] if alpha_rows else 0)
        self._problem = {"x": x, "p": p, "f": t + w_eff * effort}
        self._rows = (ca.vertcat(*eq), ca.vertcat(*piv), ca.vertcat(nom_err, *err_rows, *alpha_rows))
        self._nlps: Dict[bool, object] = {}
        self.f_tips = ca.Function("robust_tips", [x, p], [ca.horzcat(*tips)])
        self.build_time = time.perf_counter() - t0

    def nlpsol(self, certified: bool):
        """Without the stability certificate: exact Hessian (fast, superlinear); with it: the LDLᵀ
        pivots of every scenario, whose exact Hessian would need fourth derivatives of the energy,
        so a quasi-Newton Hessian. Each variant is built on first use."""
        if certified not in self._nlps:
            eq, piv, rest = self._rows
            g = ca.vertcat(eq, piv, rest) if certified else ca.vertcat(eq, rest)
            opts = {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes", "ipopt.tol": 1e-10,
                    "ipopt.acceptable_tol": 1e-7, "ipopt.max_iter": 500 if certified else 200,
                    "ipopt.mu_init": 1e-4, "ipopt.bound_push": 1e-8, "ipopt.bound_frac": 1e-8}
            if certified:
                opts["ipopt.hessian_approximation"] = "limited-memory"
            self._nlps[certified] = ca.nlpsol("robust_design", "ipopt", {**self._problem, "g": g}, opts)
        return self._nlps[certified]

    def solve(self, base_scene: Scene, tol: Tolerances, scale: float, target: Sequence[float],
              d0: np.ndarray, z0: Sequence[np.ndarray], *, margin: float, bounds: Dict[str, float],
              w_eff: float = 1e-6, certified: bool = False) -> RobustPoint:
        """Solve at ``scale`` × the tolerances from the design vector ``d0`` and scenario states
        ``z0`` (θ at all nodes: nominal first, then one per corner)."""
        b = self.base
        sv = b.solver
        P0 = sv.parameter_vector(base_scene)
        offs = _corner_offsets(tol, scale)
        ov = np.array([[o["k_h"], o["k_p"], o["dphi"], o["dalpha"], o["dtheta0"]] for o in offs]).ravel()
        use_angle = len(target) > 2
        tgt = np.array([target[0], target[1], target[2] if use_angle else 0.0])
        p = np.concatenate([P0, ov, tgt, [1.0 if use_angle else 0.0, margin, w_eff]])
        n, nd, C = self.n, self.nd, self.C
        nx = (C + 1) * n + nd + 1
        lbx, ubx = np.full(nx, -np.inf), np.full(nx, np.inf)
        off = (C + 1) * n
        if "h" in b.vary:
            lbx[off + b.dslices["h"].start], ubx[off + b.dslices["h"].start] = 0.0, bounds["h_max"]
        if "phi" in b.vary:
            lbx[off + b.dslices["phi"].start], ubx[off + b.dslices["phi"].start] = -2 * np.pi, 2 * np.pi
        if "p" in b.vary:
            lbx[off + b.dslices["p"].start], ubx[off + b.dslices["p"].start] = -bounds["p_max"], bounds["p_max"]
        lbx[-1] = 0.0
        s = self._sizes
        a_max = bounds.get("alpha_max", np.inf)
        nom_lb = np.array([0.0, 0.0, 0.0 if use_angle else -np.inf])
        nom_ub = np.array([0.0, 0.0, 0.0 if use_angle else np.inf])
        npiv = s["piv"] if certified else 0
        lbg = np.concatenate([np.zeros(s["eq"]), np.zeros(npiv), nom_lb, np.full(s["err"], -np.inf),
                              np.full(s["alpha"], -a_max)])
        ubg = np.concatenate([np.zeros(s["eq"]), np.full(npiv, np.inf), nom_ub, np.zeros(s["err"]),
                              np.full(s["alpha"], a_max)])
        zs = [np.asarray(zc, float)[1:] for zc in z0]
        # t starts at the worst corner error of the start (feasible for the epigraph rows)
        x_probe = np.concatenate(zs + [d0, [0.0]])
        tips0 = np.asarray(self.f_tips(x_probe, p), float)
        t0 = float(max(np.sum((tips0[:2, 1:] - tgt[:2, None]) ** 2, axis=0).max(initial=0.0), 1e-12))
        x0 = np.concatenate(zs + [d0, [t0]])
        nlp = self.nlpsol(certified)
        sol = nlp(x0=x0, p=p, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
        st = nlp.stats()
        x = np.asarray(sol["x"], float).ravel()
        tips = np.asarray(self.f_tips(x, p), float)
        worst = float(np.sqrt(np.sum((tips[:2, 1:] - tgt[:2, None]) ** 2, axis=0)).max(initial=0.0))
        status = str(st.get("return_status"))
        theta0 = float(P0[sv.layout.slices["theta0"]][0])
        zs_out = []
        for c in range(C + 1):
            th0 = theta0 + (offs[c - 1]["dtheta0"] if c > 0 else 0.0)
            zs_out.append(np.concatenate([[th0], x[c * n:(c + 1) * n]]))
        return RobustPoint(d=x[off:off + nd], z=zs_out, worst_error=worst,
                           converged=bool(st.get("success", False)) or status == "Solved_To_Acceptable_Level",
                           status=status, scale=scale)


_ROBUST_CACHE: Dict[tuple, RobustDesignNLP] = {}


def get_robust_nlp(base: DesignNLP, n_corners: int) -> RobustDesignNLP:
    """A cached :class:`RobustDesignNLP` (built once per design NLP and number of corners)."""
    key = (id(base), n_corners)
    if key not in _ROBUST_CACHE:
        _ROBUST_CACHE[key] = RobustDesignNLP(base, n_corners)
    return _ROBUST_CACHE[key]


@dataclass
class RobustOutcome:
    """What :func:`robustify` found: the most robust point and the largest box fraction it holds."""

    point: Optional[RobustPoint]
    scale: float  # largest fraction of the tolerances solved for (0: none)
    attempts: List[str]


def _stable_everywhere(nlp: DesignNLP, base: Scene, pt: RobustPoint, tol: Tolerances, margin: float) -> bool:
    from .tolerances import perturb
    sv = nlp.solver
    sc = nlp.scene_for(base, pt.d)
    scenes = [sc] + [perturb(sc, tol.scaled(pt.scale), c) for c in tol.corners()]
    return all(sv.stability(z, sv.parameter_vector(s)).eigenvalues[0] >= margin * (1 - 1e-6)
               for z, s in zip(pt.z, scenes))


def robustify(nlp: DesignNLP, base: Scene, d0: np.ndarray, z0: np.ndarray, target: Sequence[float],
              tol: Tolerances, *, margin: float, bounds: Dict[str, float],
              scales: Sequence[float] = (0.25, 0.5, 1.0), refine: int = 2) -> RobustOutcome:
    """Move a nominal design to one that holds over the tolerance box, by homotopy in the box size.

    Parameters
    ----------
    nlp : DesignNLP
        The nominal design NLP (its forward solver, variables and basis).
    base : Scene
        The design's base scene (values not designed).
    d0 : ndarray, shape (nd,)
        The nominal design vector; ``z0`` its equilibrium (θ at all nodes).
    target : (x, y) or (x, y, angle)
    tol : Tolerances
    margin : float
        Stability margin μ required at the nominal point and every corner.
    bounds : dict
        ``h_max``, ``p_max``, ``alpha_max`` as for the nominal design.
    scales : sequence of float
        Box fractions solved in turn, each warm-started from the last.
    refine : int
        Bisection steps between the last box fraction that worked and the first that failed (to
        report the largest box the design holds).

    Returns
    -------
    RobustOutcome
    """
    from .robustness import follow_segment
    from .tolerances import perturb

    corners = tol.corners()
    if not corners:
        return RobustOutcome(None, 1.0, ["no tolerances: nothing to robustify"])
    rnlp = get_robust_nlp(nlp, len(corners))
    sv = nlp.solver
    d, zs = np.asarray(d0, float), [np.asarray(z0, float)] * (len(corners) + 1)
    best: Optional[RobustPoint] = None
    done, attempts = 0.0, []

    def attempt(scale):
        sc = nlp.scene_for(base, d)
        Pn = sv.parameter_vector(sc)
        start = [zs[0]]
        for c, zc in zip(corners, zs[1:]):  # corner starts on the nominal branch where it reaches
            seg = follow_segment(sv, zs[0], Pn, sv.parameter_vector(perturb(sc, tol.scaled(scale), c)))
            start.append(seg.z_end if seg.completed else zc)
        pt = rnlp.solve(base, tol, scale, target, d, start, margin=margin, bounds=bounds)
        if pt.converged and not _stable_everywhere(nlp, base, pt, tol, margin):
            pt = rnlp.solve(base, tol, scale, target, d, start, margin=margin, bounds=bounds, certified=True)
            pt.converged = pt.converged and _stable_everywhere(nlp, base, pt, tol, margin)
        attempts.append(f"box x{scale:g}: {pt.status}, worst corner error {pt.worst_error:.3g}")
        return pt

    failed_at = None
    for scale in scales:
        pt = attempt(scale)
        if not pt.converged:
            failed_at = scale
            break
        best, done, d, zs = pt, scale, pt.d, pt.z
    if failed_at is not None:
        lo, hi = done, failed_at
        for _ in range(refine):
            mid = 0.5 * (lo + hi)
            pt = attempt(mid)
            if pt.converged:
                best, lo, d, zs = pt, mid, pt.d, pt.z
            else:
                hi = mid
        done = lo
    return RobustOutcome(best, done, attempts)
