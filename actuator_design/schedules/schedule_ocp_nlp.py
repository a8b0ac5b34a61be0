"""The NLP of the optimal-control schedule (:mod:`actuator_design.schedules.schedule_ocp`): N rod states with their fields
and stability certificates, the steps' durations, the actuator's rate limits.

Unknowns, in order: per node k the free nodal angles θ_k (n), the field (h_k, φ_k) (in the design
NLP's order) and the lifted Schur entries of node k's certificate; then the duration T_j (s) of
each leg (zero field to the first waypoint, then waypoint to waypoint), whose n_j steps last
Δt = T_j / n_j each. (With a free duration per step the nodes could slide along the time axis: the
field-free rotation between waypoints then sat in one long step or the next, two local optima 2 %
apart in effort that two BLAS kernels' round-off chose between. Uniform steps within a leg make
the nodes a time grid.)

Rows, in order: per node the stationarity rows g/m = 0 (THEORY §4), the certificate's pivots ≥ 0
and lifted rows = 0 (the LDLᵀ of M^-1/2 H M^-1/2 − μ I, μ the margin:
:class:`~actuator_design.inverse.ldl.SegmentedLDL`), the tip rows at a waypoint node; then per step the rate rows
±Δh − ḣ_max Δt ≤ 0, ±Δφ − φ̇_max Δt ≤ 0 and the continuity rows |Δθ| ≤ :data:`MAX_STEP_TURN`;
last the duration's cap Σ T_j ≤ T_cap (a parameter, see :meth:`ScheduleOCP.solve`).
"""
from __future__ import annotations

from typing import Dict, List, Optional, Sequence

import casadi as ca
import numpy as np

from actuator_design.inverse.layout import Blocks, ipopt_options
from actuator_design.inverse.ldl import SegmentedLDL

__all__ = ["ScheduleOCP", "MAX_STEP_TURN", "ENERGY_TIME_WEIGHT"]

#: Largest change of θ (rad, any node) between consecutive nodes: the loading path's own step bound,
#: so that consecutive nodes are states of one branch.
MAX_STEP_TURN = 0.5
#: Weight of the duration in the ``"energy"`` objective (the time of field-free steps is otherwise free).
ENERGY_TIME_WEIGHT = 1e-3
#: Relative slack of the duration when the least-effort fastest schedule is sought ("time").
TIME_SLACK = 1e-8
#: The duration's cap when it is not held (s; finite: IPOPT cannot evaluate ∞ − T).
NO_CAP = 1e6
#: IPOPT's iteration cap (it bounds the work; a solve that stops there is reported as not converged).
MAX_ITER = 500


class ScheduleOCP:
    """The optimal-control NLP over ``N`` nodes of one design NLP's states (vary = h, φ).

    Parameters
    ----------
    nlp : DesignNLP
        Built with ``vary=("h", "phi")`` on the schedule's base scene.
    base : Scene
    N : int
        Time nodes (node 0 is at zero field).
    waypoint_nodes : sequence of int
        The node of each waypoint (the last node of each leg; node 0 starts the first leg).
    waypoints : sequence of (x, y)
        Units of ℓ.
    limits : RateLimits
    margin, h_max : float
        Stability margin μ at every node; the field bound.
    objective : {"time", "energy"}
    """

    def __init__(self, nlp, base, N: int, waypoint_nodes: Sequence[int], waypoints, limits, margin: float,
                 h_max: float, objective: str):
        sv = nlp.solver
        self.nlp, self.N, self.n, self.nd = nlp, N, nlp.n, nlp.nd
        self.ih, self.iphi = nlp.dmap["h"].start, nlp.dmap["phi"].start
        P0 = ca.DM(sv.parameter_vector(base))
        state = nlp.state_function()
        at = dict(zip(waypoint_nodes, waypoints))
        xs, rows = Blocks(), Blocks()
        self.thetas, self.ds, self.certs, self.schur = [], [], [], []
        for k in range(N):
            th, d = ca.SX.sym(f"theta_{k}", self.n), ca.SX.sym(f"d_{k}", self.nd)
            eq, A = state(th, d, P0)
            cert = SegmentedLDL(A - margin * ca.SX.eye(self.n))
            self.thetas.append(th), self.ds.append(d), self.certs.append(cert)
            self.schur.append(ca.Function(f"schur_{k}", [th, d, cert.v], [cert.schur]))
            lo_d, hi_d = np.full(self.nd, -np.inf), np.full(self.nd, np.inf)
            lo_d[self.ih], hi_d[self.ih] = 0.0, (0.0 if k == 0 else h_max)  # from zero field
            xs.add(f"theta_{k}", th)
            xs.add(f"d_{k}", d, lo_d, hi_d)
            xs.add(f"lifted_{k}", cert.v)
            rows.add(f"eq_{k}", eq, 0.0, 0.0)
            rows.add(f"pivots_{k}", cert.pivots, 0.0, np.inf)
            rows.add(f"lifted_{k}", cert.rows, 0.0, 0.0)
            if k in at:
                tip = nlp.f_tip(th, d, P0)
                rows.add(f"waypoint_{k}", tip[:2] - ca.DM(at[k]), 0.0, 0.0)
        legs = np.diff([0, *waypoint_nodes])
        T = ca.SX.sym("T", len(legs))
        xs.add("durations", T, 0.0, np.inf)
        dt = ca.vertcat(*[T[j] / int(n) for j, n in enumerate(legs) for _ in range(int(n))])
        self.legs = legs
        h = [d[self.ih] for d in self.ds]
        phi = [d[self.iphi] for d in self.ds]
        for k in range(N - 1):
            dh, dphi = h[k + 1] - h[k], phi[k + 1] - phi[k]
            rows.add(f"rates_{k}", ca.vertcat(dh - limits.h_rate * dt[k], -dh - limits.h_rate * dt[k],
                                              dphi - limits.rotation_rate * dt[k], -dphi - limits.rotation_rate * dt[k]),
                     -np.inf, 0.0)
            rows.add(f"turn_{k}", self.thetas[k + 1] - self.thetas[k], -MAX_STEP_TURN, MAX_STEP_TURN)
        # f = w_T·T + w_E·∫h² dt, and T ≤ T_cap (a row): "energy" is one solve with a small w_T; "time"
        # is two (lexicographic): the least T, then the least effort with T held at it. The
        # time-optimal schedules form a family (h may wander while the rotation sets the pace: two
        # BLAS kernels' round-off picked efforts 14 and 75 h²·s at the same T); the second solve
        # picks its one least-effort member.
        self.p = ca.SX.sym("p", 3)  # w_T, w_E, T_cap
        # ∫h² dt with h linear in time within each step (as the loading path follows it)
        effort = sum(dt[k] * (h[k] ** 2 + h[k] * h[k + 1] + h[k + 1] ** 2) / 3 for k in range(N - 1))
        f = self.p[0] * ca.sum1(T) + self.p[1] * effort
        rows.add("time_cap", ca.sum1(T) - self.p[2], -np.inf, 0.0)
        self.objective = objective
        self.x = xs.vector()
        self.lbg, self.ubg = rows.bounds()
        self.lbx, self.ubx = xs.bounds()
        self.offsets: List[int] = [xs[f"theta_{k}"].start for k in range(N)]
        # the start is a stable schedule within the limits: a small barrier keeps it near
        opts = ipopt_options(tol=1e-9, acceptable_tol=1e-7, max_iter=MAX_ITER, mu_init=1e-6, bound_push=1e-8,
                             bound_frac=1e-8)
        self.solver = ca.nlpsol("schedule_ocp", "ipopt", {"x": self.x, "p": self.p, "f": f, "g": rows.vector()}, opts)
        self.status = "not_solved"

    def solve(self, start: Dict[str, object]) -> Optional[Dict[str, np.ndarray]]:
        """Solve from ``start`` (``theta``: per node θ at all nodes, rad; ``h``, ``phi``; ``dt``:
        per step, uniform within each leg):
        ``{"h", "phi", "dt", "theta"}`` (theta: per node the free nodal angles), or None when
        IPOPT did not converge (``status`` says how it stopped)."""
        x0 = []
        for k in range(self.N):
            th = np.asarray(start["theta"][k], float)[1:]
            d = np.zeros(self.nd)
            d[self.ih], d[self.iphi] = start["h"][k], start["phi"][k]
            x0 += [th, d, self.certs[k].start(self.schur[k], th, d)]
        dt = np.asarray(start["dt"], float)
        ends = np.cumsum(self.legs)
        x0.append(np.array([dt[e - n: e].sum() for e, n in zip(ends, self.legs)]))
        if self.objective == "energy":
            xs = self._solve(np.concatenate(x0), [ENERGY_TIME_WEIGHT, 1.0, NO_CAP])
        else:
            xs = self._solve(np.concatenate(x0), [1.0, 0.0, NO_CAP])
            if xs is not None:  # the least effort among the fastest (else the fastest found first)
                fastest = float(np.sum(xs[-len(self.legs):]))
                least = self._solve(xs, [0.0, 1.0, fastest * (1 + TIME_SLACK)])
                if least is None:
                    self.status = f"{self.status} (least-effort solve; the fastest schedule is kept)"
                xs = least if least is not None else xs
        if xs is None:
            return None
        out = {"h": [], "phi": [], "theta": []}
        for k, off in enumerate(self.offsets):
            d = xs[off + self.n: off + self.n + self.nd]
            out["theta"].append(xs[off: off + self.n])
            # (IPOPT relaxes bounds by ~1e-8: h = −1e-8 where the field is off is h = 0)
            out["h"].append(float(np.clip(d[self.ih], self.lbx[off + self.n + self.ih], self.ubx[off + self.n + self.ih])))
            out["phi"].append(float(d[self.iphi]))
        T = xs[-len(self.legs):]
        out["dt"] = np.concatenate([np.full(int(n), T[j] / int(n)) for j, n in enumerate(self.legs)])
        return {k: np.asarray(v) for k, v in out.items()}

    def _solve(self, x0: np.ndarray, p) -> Optional[np.ndarray]:
        sol = self.solver(x0=x0, p=p, lbx=self.lbx, ubx=self.ubx, lbg=self.lbg, ubg=self.ubg)
        self.status = self.solver.stats()["return_status"]
        if self.status not in ("Solve_Succeeded", "Solved_To_Acceptable_Level"):
            return None
        return np.asarray(sol["x"], float).ravel()
