"""Robust and multi-pose design: one actuator that reaches its targets and stays put over the box.

The nominal design NLP (:mod:`actuator_design.inverse.nlp`) minimises effort, which drives a design onto the fold
where its branch ends: there, a fraction of a per cent less field and the rod snaps. Here a design
is posed over the tolerance box instead, as a multi-scenario NLP. For poses k = 1..K (one shared
fibre layout α(s), one field (h_k, φ_k[, p_k]) per pose) and the box's corners c = 1..C:

    min   Σ_k t_k + w · effort(d)
    s.t.  ∇Ê(θ_kc; P_kc(d)) = 0                    every pose k, scenario c = 0 (nominal), 1..C
          LDLᵀ pivots of M^-½ H(θ_kc) M^-½ − μ I ≥ 0   (stable with margin μ; see below)
          tip(θ_k0) = target_k                      each pose reaches its target exactly
          |tip(θ_kc) − target_k|² ≤ t_k              worst-case tip error of pose k over the corners

Why this formulation: the worst-case tip error over the corners is the quantity a user builds on,
and requiring every corner to be a stable equilibrium pushes every fold out of the box (a fold
inside the box would leave a corner without its stable state). Whether the corners' states lie on
the nominal state's branch is not part of the NLP: :func:`actuator_design.robust.robustness.evaluate_robustness` checks
it afterwards by following the branch along rays and edges, and that check decides.

The NLP is solved first with the exact Hessian and without the stability rows (fast); only if a
scenario's state then fails λ_min ≥ μ is the certified variant (LDLᵀ pivots, quasi-Newton Hessian:
the exact one would need fourth derivatives of the energy) solved. The box is reached by homotopy
in its size (¼, ½, 1 of the tolerances), each stage warm-started from the last, so the largest box
a design holds is known when the full box fails.

P_kc(d) maps the design vector and the corner's offsets (NLP parameters, so the box can change
without a rebuild) to the forward NLP's parameter vector, with the scalings of :mod:`actuator_design.robust.tolerances`:
every slot a relative tolerance moves scaled by its factor (the lens' power laws: h ∝ H√(χ̄/E),
h_r ∝ H/E, loads ∝ 1/E; THEORY §5, §9), φ, α and θ0 shifted.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence

import casadi as ca
import numpy as np

from actuator_design.inverse.design_map import DesignVector, certificate_matrix
from actuator_design.inverse.layout import Blocks, DesignStates, Variant, ipopt_options, outcome, profile_rows
from actuator_design.inverse.ldl import (CERTIFICATE_REFUSED, Certificate, CertificateTooLarge, _bandwidth,
                                         check_certificate_size)
from actuator_design.inverse.nlp import _LENS_VARIABLES, DesignNLP
from actuator_design.model.scene import Scene
from actuator_design.robust.robustness import follow_segment
from actuator_design.robust.tolerances import Tolerances, perturb, scale_factor, scaled_slots

__all__ = ["ScenarioDesignNLP", "ScenarioPoint", "RobustOutcome", "robustify", "get_scenario_nlp",
           "pose_designs"]

_PER_POSE = _LENS_VARIABLES  # the scalar design variables (h, phi, p): one set per pose
_N_ANGLES = 3  # angle shifts per corner scenario after the scale factors: dphi, dalpha, dtheta0


def __getattr__(name):  # ``_SCALED``: the slots a relative tolerance scales, read from the lens when asked
    if name == "_SCALED":
        return tuple(p.slot for p in scaled_slots())
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


@dataclass
class ScenarioPoint:
    """One solve of the scenario NLP.

    d : the full design vector (shared α, then β coefficients, then h, φ, p of each pose as varied).
    z : θ at all nodes per pose and scenario, z[k][c] (c = 0 nominal, then the corners).
    worst_error : per pose, max over corners of |tip − target| (units of ℓ), from the NLP's states.
    """

    d: np.ndarray
    z: List[List[np.ndarray]]
    worst_error: List[float]
    converged: bool
    status: str
    scale: float


def _corner_offsets(tol: Tolerances, scale: float, slots: Sequence[str]) -> List[List[float]]:
    """Per corner: the factor on each of ``slots`` (:func:`~actuator_design.robust.tolerances.scale_factor`,
    as the forward check's :func:`~actuator_design.robust.tolerances.apply_deltas` scales it: the field
    groups ∝ H, E and χ̄ by their power laws, loads ∝ 1/E, THEORY §5, §9), then dphi, dalpha, dtheta0."""
    by_slot = {p.slot: p for p in scaled_slots()}
    out = []
    for c in tol.corners():
        g = {a: c.get(a, 0.0) * getattr(tol, a) * scale for a in
             ("field_rel", "angle", "youngs_rel", "chi_rel", "fibre_angle", "clamp_angle")}
        out.append([scale_factor(by_slot[s], g) for s in slots] + [g["angle"], g["fibre_angle"], g["clamp_angle"]])
    return out


class ScenarioDesignNLP:
    """The multi-scenario design NLP: K poses sharing α(s) (and β(s) when designed), C corners each.

    Parameters
    ----------
    base : DesignNLP
        The single-pose design NLP: its forward solver, variables and Legendre basis are reused.
    n_poses : int
        K ≥ 1.
    n_corners : int
        C ≥ 0 corner scenarios per pose (2^k for k active tolerances; 0 for a nominal design).
    """

    def __init__(self, base: DesignNLP, n_poses: int, n_corners: int):
        t0 = time.perf_counter()
        self.base, self.K, self.C = base, int(n_poses), int(n_corners)
        sv, lay, sl = base.solver, base.solver.layout, base.solver.layout.slices
        n, K, C = base.n, self.K, self.C
        self.n = n
        self.per_pose = tuple(v for v in _PER_POSE if v in base.vary)
        #: the shared profiles (α, then β when designed), each ``base.alpha_terms`` coefficients
        self.profiles = base.profiles
        #: the design vector: the shared profiles, then each pose's scalars
        self.dmap = DesignVector.poses(self.profiles, self.per_pose, K, base.alpha_terms)
        d = ca.SX.sym("d", self.nd)
        P0 = ca.SX.sym("P0", lay.size)
        #: the slots a corner scales (the field groups, loads, plug-in values: from the lens)
        self.scaled = tuple(p.slot for p in scaled_slots() if p.slot in sl)
        n_off = len(self.scaled) + _N_ANGLES
        offs = ca.SX.sym("offsets", n_off * max(C, 1))
        target = ca.SX.sym("target", 3 * K)
        w_ang, margin, w_eff = ca.SX.sym("w_ang"), ca.SX.sym("margin"), ca.SX.sym("w_eff")
        t = ca.SX.sym("t", K)
        m = sv.transcription.mass[1:]
        bw = _bandwidth(sv, n)
        shared = self.dmap.shared_values(d)

        def scenario(P, c):  # corner c ≥ 1 of the box
            vals = offs[n_off * (c - 1):n_off * c]
            Pc = ca.SX(P)
            for i, slot in enumerate(self.scaled):
                Pc[sl[slot]] = P[sl[slot]] * vals[i]
            dphi, dal, dth = (vals[n_off - _N_ANGLES + i] for i in range(_N_ANGLES))
            if "phi" in sl:
                Pc[sl["phi"]] = P[sl["phi"]] + dphi
            if "alpha" in sl:
                Pc[sl["alpha"]] = P[sl["alpha"]] + dal
            Pc[sl["theta0"]] = P[sl["theta0"]] + dth
            return Pc

        # the single-pose map per pose (h moves the groups the field drives, THEORY §9); with
        # obstacles, every scenario's rod keeps clear of them (:mod:`actuator_design.contact.clearance`)
        states = DesignStates(sv, self.dmap, d, P0, base.vandermonde, C, scenario, base.obstacles, base.gap)
        eq, mats, nom, err, tips, sq, clear = [], [], [], [], [], [], []
        for k in range(K):
            tgt = target[3 * k:3 * k + 3]
            for c in range(C + 1):
                state = states.rows[k * (C + 1) + c]
                eq.append(state.eq)
                mats.append(certificate_matrix(state.hessian, m, margin))
                tip = state.tip
                tips.append(tip)
                clear.append(state.clear)
                e = tip - tgt
                if c == 0:
                    nom.append(e)
                else:
                    err.append(e[0] ** 2 + e[1] ** 2 + w_ang * e[2] ** 2 - t[k])
                    sq.append(e[0] ** 2 + e[1] ** 2 + w_ang * e[2] ** 2)
        effort = self.dmap.effort(d)  # every pose's scalars, the shared profiles once
        xs = Blocks()
        xs.add("states", ca.vertcat(*states.z))  # θ of pose k, scenario c at block k (C + 1) + c
        xs.add("d", d)  # bounded by the request (solve)
        xs.add("t", t, 0.0, np.inf)  # the worst squared corner error of each pose
        x = xs.vector()
        p = ca.vertcat(P0, offs, target, w_ang, margin, w_eff)
        # the worst case, regularised by the mean square (a pure minimax has degenerate multipliers
        # when several corners are active, which slows IPOPT down near the solution)
        f = (ca.sum1(t) + 0.1 * sum(sq) / C if C else 0) + w_eff * effort
        self._problem = {"x": x, "p": p, "f": f}
        self._x = xs
        self._rows = dict(eq=ca.vertcat(*eq), pivots=Certificate(mats, bandwidth=bw).pivots, nominal=ca.vertcat(*nom),
                          corners=ca.vertcat(*err), profiles=profile_rows(base.vandermonde, shared, self.profiles),
                          clear=ca.vertcat(*clear))
        self._variants: Dict[bool, Variant] = {}
        self.f_tips = ca.Function("scenario_tips", [x, p], [ca.horzcat(*tips)])
        self.build_time = time.perf_counter() - t0

    # -- layout of the design vector ------------------------------------------------------------
    @property
    def nd(self) -> int:
        """Length of the design vector."""
        return self.dmap.size

    def pose_vector(self, d: np.ndarray, k: int) -> np.ndarray:
        """The single-pose design vector (of :class:`DesignNLP`) of pose k."""
        return self.dmap.move(np.asarray(d, float), k, self.base.dmap, np.zeros(self.base.nd))

    def join(self, pose_vectors: Sequence[np.ndarray]) -> np.ndarray:
        """The scenario design vector from single-pose vectors (α and β taken from the first)."""
        d = np.zeros(self.nd)
        for k in reversed(range(len(pose_vectors))):  # the first pose's profiles written last
            self.base.dmap.move(np.asarray(pose_vectors[k], float), 0, self.dmap, d, into_pose=k)
        return d

    def _profile_bounds(self, bounds: Dict[str, float]):
        """Bounds of the profile rows, as the single-pose NLP's: |α(s_q)| ≤ alpha_max, then |β(s_q)|."""
        return self.base.profile_bounds(bounds)

    def nlpsol(self, certified: bool):
        """Without the stability rows: exact Hessian; with them: quasi-Newton (built on first use)."""
        return self._variant(certified).solver

    def _variant(self, certified: bool) -> Variant:
        if certified:
            check_certificate_size(self.base.solver, self.n, self.K * (self.C + 1), exact_hessian=False)
        if certified not in self._variants:
            q, rows = self._rows, Blocks()
            rows.add("eq", q["eq"], 0.0, 0.0)
            if certified:
                rows.add("pivots", q["pivots"], 0.0, np.inf)
            rows.add("nominal", q["nominal"])  # each pose's nominal tip: pinned (solve)
            rows.add("corners", q["corners"], -np.inf, 0.0)  # each corner's squared error ≤ t_k
            rows.add("profiles", q["profiles"])  # bounded by the request (_profile_bounds)
            rows.add("clear", q["clear"], 0.0, np.inf)
            opts = ipopt_options(tol=1e-10, acceptable_tol=1e-7, max_iter=500, mu_init=1e-4, bound_push=1e-8,
                                 bound_frac=1e-8, **({"hessian_approximation": "limited-memory"} if certified else {}))
            nlp = ca.nlpsol("scenario_design", "ipopt", {**self._problem, "g": rows.vector()}, opts)
            self._variants[certified] = Variant(nlp, self._x, rows)
        return self._variants[certified]

    def solve(self, base_scene: Scene, tol: Tolerances, scale: float, targets: Sequence[Sequence[float]],
              d0: np.ndarray, z0: Sequence[Sequence[np.ndarray]], *, margin: float,
              bounds: Dict[str, float], w_eff: float = 1e-6, certified: bool = False) -> ScenarioPoint:
        """Solve at ``scale`` × the tolerances from the design vector ``d0`` and the states
        ``z0[k][c]`` (θ at all nodes; c = 0 the nominal state of pose k, then its corners)."""
        sv, K, C, n = self.base.solver, self.K, self.C, self.n
        P0 = sv.parameter_vector(base_scene)
        offs = _corner_offsets(tol, scale, self.scaled) if C else []
        ov = np.array(offs).ravel() if C else np.array([1.0] * len(self.scaled) + [0.0] * _N_ANGLES)
        use_angle = any(len(tg) > 2 for tg in targets)
        tgt = np.concatenate([[tg[0], tg[1], tg[2] if len(tg) > 2 else 0.0] for tg in targets])
        p = np.concatenate([P0, ov, tgt, [1.0 if use_angle else 0.0, margin, w_eff]])
        nz = K * (C + 1) * n
        lo_d, hi_d = self.dmap.bounds(bounds)
        if self.base.gauge:  # α's mean pinned at 0, every pose's φ moved with it (DesignNLP.fix_gauge)
            d0 = self.dmap.fix_gauge(d0)
            i0 = self.dmap.slice("alpha").start  # α's mean c_0
            lo_d[i0] = hi_d[i0] = 0.0
        lbx, ubx = self._x.bounds(d=(lo_d, hi_d))
        nominal = (np.tile([0.0, 0.0, 0.0 if use_angle else -np.inf], K),
                   np.tile([0.0, 0.0, 0.0 if use_angle else np.inf], K))
        zs = [np.asarray(zc, float)[1:] for zk in z0 for zc in zk]
        tips0 = np.asarray(self.f_tips(np.concatenate(zs + [d0, np.zeros(K)]), p), float)
        t0 = [self._worst(tips0, tgt, k) ** 2 + 1e-12 for k in range(K)]
        if certified:
            try:
                check_certificate_size(sv, n, K * (C + 1), exact_hessian=False)
            except CertificateTooLarge as err:  # not a solve: the start, marked as not converged
                return ScenarioPoint(d=np.asarray(d0, float), z=[list(zk) for zk in z0], worst_error=[math.inf] * K,
                                     converged=False, status=str(err), scale=scale)
        nlp = self.nlpsol(certified)
        lbg, ubg = self._variant(certified).rows.bounds(nominal=nominal, profiles=self._profile_bounds(bounds))
        sol = nlp(x0=np.concatenate(zs + [d0, t0]), p=p, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
        converged, status = outcome(nlp)
        x = np.asarray(sol["x"], float).ravel()
        tips = np.asarray(self.f_tips(x, p), float)
        theta0 = float(P0[sv.layout.slices["theta0"]][0])
        z_out = []
        for k in range(K):
            row = []
            for c in range(C + 1):
                j = k * (C + 1) + c
                th0 = theta0 + (offs[c - 1][-1] if c > 0 else 0.0)  # the corner's dtheta0
                row.append(np.concatenate([[th0], x[j * n:(j + 1) * n]]))
            z_out.append(row)
        return ScenarioPoint(d=x[nz:nz + self.nd], z=z_out, worst_error=[self._worst(tips, tgt, k) for k in range(K)],
                             converged=converged, status=status, scale=scale)

    def _worst(self, tips: np.ndarray, tgt: np.ndarray, k: int) -> float:
        C = self.C
        if C == 0:
            return 0.0
        cols = tips[:2, k * (C + 1) + 1:(k + 1) * (C + 1)]
        return float(np.sqrt(np.sum((cols - tgt[3 * k:3 * k + 2, None]) ** 2, axis=0)).max())


_CACHE: Dict[tuple, ScenarioDesignNLP] = {}


def get_scenario_nlp(base: DesignNLP, n_poses: int, n_corners: int) -> ScenarioDesignNLP:
    """A cached :class:`ScenarioDesignNLP` (built once per design NLP, poses and corners)."""
    key = (id(base), n_poses, n_corners)
    if key not in _CACHE:
        _CACHE[key] = ScenarioDesignNLP(base, n_poses, n_corners)
    return _CACHE[key]


@dataclass
class RobustOutcome:
    """What :func:`robustify` found: the most robust point and the largest box fraction it holds."""

    point: Optional[ScenarioPoint]
    scale: float  # largest fraction of the tolerances solved for (0: none)
    attempts: List[str]
    nlp: Optional[ScenarioDesignNLP] = None
    #: every step of the homotopy that worked, in order (the last is ``point``): (box fraction,
    #: ScenarioPoint) from :func:`robustify`; the robust stage's forked task sends (fraction, d, z)
    ladder: List[tuple] = field(default_factory=list)


def pose_designs(nlp: ScenarioDesignNLP, base: Scene, d: np.ndarray) -> List[Scene]:
    """The forward scene of each pose."""
    return [nlp.base.scene_for(base, nlp.pose_vector(d, k)) for k in range(nlp.K)]


def _stable_everywhere(snlp: ScenarioDesignNLP, base: Scene, pt: ScenarioPoint, tol: Tolerances,
                       margin: float) -> bool:
    sv = snlp.base.solver
    for sc, zk in zip(pose_designs(snlp, base, pt.d), pt.z):
        scenes = [sc] + [perturb(sc, tol.scaled(pt.scale), c) for c in tol.corners()][:snlp.C]
        if not all(sv.stability(z, sv.parameter_vector(s)).eigenvalues[0] >= margin * (1 - 1e-6)
                   for z, s in zip(zk, scenes)):
            return False
    return True


#: Largest turn (rad) of any point of a pose's states (nominal and corners) in one step of the box
#: homotopy. The homotopy follows one design as the box grows; a converged solve whose states
#: jumped has left it (target (0.4178, 0.4979): one kernel's solve of the first quarter jumped to
#: a design whose worst corner error was 0.93 rod lengths, where the other's path ends at 0.010). As the verification's
#: path follower (max_dtheta, :mod:`actuator_design.inverse.verify`).
MAX_SHAPE_TURN = 0.5


def _continuous(z_from: Sequence[Sequence[np.ndarray]], z_to: Sequence[Sequence[np.ndarray]]) -> bool:
    """Every state of every pose (its nominal state and its corners; θ at all nodes) turned by at
    most :data:`MAX_SHAPE_TURN`."""
    return all(float(np.max(np.abs(np.asarray(b) - np.asarray(a)), initial=0.0)) <= MAX_SHAPE_TURN
               for row_a, row_b in zip(z_from, z_to) for a, b in zip(row_a, row_b))


def robustify(nlp: DesignNLP, base: Scene, d0: Sequence[np.ndarray], z0: Sequence[np.ndarray],
              targets: Sequence[Sequence[float]], tol: Tolerances, *, margin: float, bounds: Dict[str, float],
              first_step: float = 0.25, max_step: float = 0.25, min_step: float = 1.0 / 64) -> RobustOutcome:
    """Move a (multi-pose) nominal design to one that holds over the tolerance box, by homotopy in
    the box size.

    Parameters
    ----------
    nlp : DesignNLP
        The single-pose design NLP (its forward solver, variables and basis).
    base : Scene
        The design's base scene (values not designed).
    d0 : sequence of ndarray
        Per pose, the nominal single-pose design vector (the fibre layout of the first is shared).
    z0 : sequence of ndarray
        Per pose, the nominal equilibrium (θ at all nodes, rad).
    targets : sequence of (x, y) or (x, y, angle)
    tol : Tolerances
    margin : float
        Stability margin μ required at every pose's nominal point and corners.
    bounds : dict
        ``h_max``, ``p_max``, ``alpha_max`` as for the nominal design.
    first_step, max_step, min_step : float
        Step control of the homotopy in the box fraction s ∈ [0, 1], each solve warm-started from
        the last design: steps of a quarter (0.25, 0.5, 0.75, 1) while they succeed; a step that
        fails is halved and retried, one that succeeds after that doubles again (up to
        ``max_step``), and the homotopy stops at the last fraction that worked only when the step
        falls below ``min_step``. A converged step whose states (nominal or corner) turned by more
        than :data:`MAX_SHAPE_TURN` has jumped to another design and counts as failed. The ladder alone let an iteration limit decide: at target
        (0.232, 0.498) the first step's certified solve hit the 150-iteration cap with one
        OpenBLAS kernel and converged with another, and the design ended at h = 4.41 (not
        verifiable) and 7.62 (issue 17); with the retry both kernels end at 7.62. (Smaller first
        steps are no better: the worst-case objective then follows its slow drift to larger
        fields, e.g. to the h bound at target (0.6, 0.6). From 0.5 straight to 1 the solve wandered
        (target (0.536, 0.450): h = 5.73 and 8.81 on two kernels); a quarter keeps each solve short.)

    Returns
    -------
    RobustOutcome
    """
    corners = tol.corners()
    K = len(targets)
    snlp = get_scenario_nlp(nlp, K, len(corners))
    sv = nlp.solver
    d = snlp.join(d0)
    zs = [[np.asarray(z, float)] * (len(corners) + 1) for z in z0]
    best: Optional[ScenarioPoint] = None
    done, attempts, ladder = 0.0, [], []

    def attempt(scale):
        start = []
        for sc, zk in zip(pose_designs(snlp, base, d), zs):
            Pn = sv.parameter_vector(sc)
            row = [zk[0]]
            for c, zc in zip(corners, zk[1:]):  # corner starts on the nominal branch where it reaches
                seg = follow_segment(sv, zk[0], Pn, sv.parameter_vector(perturb(sc, tol.scaled(scale), c)))
                row.append(seg.z_end if seg.completed else zc)
            start.append(row)
        pt = snlp.solve(base, tol, scale, targets, d, start, margin=margin, bounds=bounds)
        if pt.converged and not _stable_everywhere(snlp, base, pt, tol, margin):
            pt = snlp.solve(base, tol, scale, targets, d, start, margin=margin, bounds=bounds, certified=True)
            pt.converged = pt.converged and _stable_everywhere(snlp, base, pt, tol, margin)
        attempts.append(f"box x{scale:g}: {pt.status}, worst corner error "
                        f"{max(pt.worst_error, default=0.0):.3g}")
        return pt

    if not corners:  # no tolerance is active: the nominal (multi-pose) problem, solved once
        pt = attempt(1.0)
        if pt.converged:
            best, done = pt, 1.0
        return RobustOutcome(best, done, attempts, snlp)
    step = first_step
    while done < 1.0 and step >= min_step:
        scale = min(1.0, done + step)
        pt = attempt(scale)
        if pt.converged and not _continuous(zs, pt.z):
            attempts[-1] += f" (rejected: a state turned by more than {MAX_SHAPE_TURN:g} rad in one step)"
            pt.converged = False
        if pt.converged:
            best, done, d, zs = pt, scale, pt.d, pt.z
            ladder.append((scale, pt))
            step = min(2.0 * step, max_step)
        elif pt.status.startswith(CERTIFICATE_REFUSED):
            break  # a smaller box has the same dense Hessian: the certificate stays refused
        else:
            step *= 0.5
    return RobustOutcome(best, done, attempts, snlp, ladder)
