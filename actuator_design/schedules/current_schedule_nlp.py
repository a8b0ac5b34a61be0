"""The optimal-control NLP of a schedule over coil currents (:mod:`actuator_design.schedules.current_schedule`): the coils'
currents at N time nodes and the legs' durations, within the drivers' limits, with the currents at
each waypoint's node pinned to ones that put the tip on the waypoint.

Unknowns: per node k the weights u_k (n_coils; I = u I0, I0 the currents the coils were fitted at),
then each leg's duration T_j (s; its n_j steps last T_j / n_j). Bounds: |u_k| ≤ max_current / |I0|,
u_0 = 0 (the coils start off), u at waypoint j's node = the pinned weights. Rows: per node the power
Σ R I² ≤ max_power (with a limit), per step |Δu_i| ≤ slew_i / |I0_i| Δt, and Σ T_j ≤ T_cap.
Objective: the energy ∫ Σ R_k I_k² dt (exact for currents linear in time within a step), then the
least duration at it; or the duration, then the least energy at it.

Why the rod's states are not unknowns here (unlike the ideal field's :class:`~actuator_design.schedules.schedule_ocp_nlp.ScheduleOCP`):
in a fitted coil field the reduced Hessian is dense in the angles (each point's field depends on
every angle before it), so a node's LDLᵀ certificate written out took ~9e6 instructions and its
Jacobian over 20 GiB; without it (stationarity rows and a quasi-Newton Hessian) 40 nodes ran for
more than 10 minutes. Between the waypoints the rod's state enters neither the objective nor the
drivers' limits; at the waypoints it is pinned by the currents. Stability at every node, the field
on the rod, the absence of snaps and the waypoints are checked on the loading path that replays the
schedule from zero currents (:mod:`actuator_design.schedules.current_schedule`).
"""
from __future__ import annotations

from typing import Dict, Optional, Sequence

import casadi as ca
import numpy as np

from actuator_design.inverse.layout import Blocks, ipopt_options

__all__ = ["CurrentOCP", "ENERGY_TIME_WEIGHT", "MAX_ITER"]

#: Weight of the duration in the ``"energy"`` objective (the time of current-free steps is otherwise free).
ENERGY_TIME_WEIGHT = 1e-3
#: Relative slack of the duration when the least-energy fastest schedule is sought ("time").
TIME_SLACK = 1e-8
#: The duration's (s) and the energy's (J) cap when they are not held.
NO_CAP = 1e9
#: IPOPT's iteration cap (bounds the work; a solve that stops there is reported as not converged).
MAX_ITER = 500


class CurrentOCP:
    """The controls-only optimal-control NLP of a coil schedule.

    Parameters
    ----------
    N : int
        Time nodes.
    waypoint_nodes : sequence of int
        Each waypoint's node (the last node of each leg).
    bound, rates, effort : ndarray, shape (n_coils,)
        Largest |u|; largest |du/dt| (1/s); R I0² (W per unit weight², or I0² without resistances).
    power : ndarray, shape (n_coils,), optional
        R I0² for the power row; with ``max_power`` (W, finite).
    objective : {"energy", "time"}
    """

    def __init__(self, N: int, waypoint_nodes: Sequence[int], bound: np.ndarray, rates: np.ndarray,
                 effort: np.ndarray, power: Optional[np.ndarray], max_power: float, objective: str):
        nu = bound.size
        self.N, self.nu, self.objective = N, nu, objective
        self.waypoint_nodes = list(waypoint_nodes)
        self.legs = np.diff([0, *waypoint_nodes])
        U = ca.SX.sym("u", nu, N)
        T = ca.SX.sym("T", len(self.legs))
        dt = ca.vertcat(*[T[j] / int(n) for j, n in enumerate(self.legs) for _ in range(int(n))])
        rows = Blocks()
        for k in range(N - 1):
            du = U[:, k + 1] - U[:, k]
            rows.add(f"slew_{k}", ca.vertcat(du - ca.DM(rates) * dt[k], -du - ca.DM(rates) * dt[k]), -np.inf, 0.0)
        if power is not None and np.isfinite(max_power):
            for k in range(N):
                rows.add(f"power_{k}", ca.dot(ca.DM(power), U[:, k] ** 2), -np.inf, max_power)
        c = ca.DM(np.asarray(effort, float))
        energy = sum(dt[k] * ca.dot(c, U[:, k] ** 2 + U[:, k] * U[:, k + 1] + U[:, k + 1] ** 2) / 3 for k in range(N - 1))
        self.p = ca.SX.sym("p", 4)  # w_T, w_E, T_cap, E_cap
        rows.add("caps", ca.vertcat(ca.sum1(T) - self.p[2], energy - self.p[3]), -np.inf, 0.0)
        self.x = ca.vertcat(ca.vec(U), T)
        self._energy = ca.Function("energy", [self.x], [energy])
        self.lbg, self.ubg = rows.bounds()
        self.bound = np.asarray(bound, float)
        opts = ipopt_options(tol=1e-10, acceptable_tol=1e-8, acceptable_constr_viol_tol=1e-9, max_iter=MAX_ITER)
        self.solver = ca.nlpsol("current_ocp", "ipopt",
                                {"x": self.x, "p": self.p, "f": self.p[0] * ca.sum1(T) + self.p[1] * energy,
                                 "g": rows.vector()}, opts)
        self.status = "not_solved"

    def solve(self, u0: np.ndarray, dt0: np.ndarray, pinned: np.ndarray) -> Optional[Dict[str, np.ndarray]]:
        """From the start ``u0`` (N, nu) and step durations ``dt0`` (N − 1,) (uniform within each
        leg), with the weights ``pinned`` (n_waypoints, nu) at the waypoints' nodes:
        ``{"u": (N, nu), "dt": (N − 1,)}``, or None when IPOPT did not converge (``status``)."""
        lbu = np.tile(-self.bound, (self.N, 1))
        ubu = np.tile(self.bound, (self.N, 1))
        lbu[0] = ubu[0] = 0.0
        for k, w in zip(self.waypoint_nodes, pinned):
            lbu[k] = ubu[k] = w
        u0 = np.clip(np.asarray(u0, float), lbu, ubu)
        ends = np.cumsum(self.legs)
        T0 = np.array([np.asarray(dt0)[e - n: e].sum() for e, n in zip(ends, self.legs)])
        lbx = np.concatenate([lbu.ravel(), np.zeros(T0.size)])
        ubx = np.concatenate([ubu.ravel(), np.full(T0.size, np.inf)])
        x0 = np.concatenate([u0.ravel(), T0])
        # lexicographic: the least energy, then the fastest at it ("energy"); the fastest, then the
        # least energy at it ("time"). Least-energy schedules form a discrete family (a leg's ramp at
        # full slew over m of its n equal steps costs the same for every m, and the leg lasts n/m
        # times the ramp), between whose members the energy rises: the fastest at the least energy
        # is sought from the least-energy schedule and from the fastest schedule, the shorter kept
        # (a 0 → 3 A ramp at 20 A/s: 1.2 s from the first, 0.15 s from the second).
        fastest = self._fastest(x0, lbx, ubx, T0.size)
        xs = fastest
        if self.objective == "energy":
            status = self.status
            for x_from in (x0, fastest):  # the least energy, from the start and from the fastest schedule
                got = None if x_from is None else self._solve(x_from, lbx, ubx, [ENERGY_TIME_WEIGHT, 1.0, NO_CAP, NO_CAP])
                if got is not None and (xs is None or float(self._energy(got)) < float(self._energy(xs)) * (1 - 1e-9)):
                    xs, status = got, self.status
            if xs is not None:
                cap = float(self._energy(xs)) * (1 + TIME_SLACK) + 1e-12
                candidates = [fastest] + [None if x is None else self._solve(x, lbx, ubx, [1.0, 0.0, NO_CAP, cap])
                                          for x in (xs, fastest)]
                for got in candidates:  # (the fastest schedule itself may cost the least energy)
                    if got is not None and float(self._energy(got)) <= cap and \
                            np.sum(got[-T0.size:]) < np.sum(xs[-T0.size:]):
                        xs = got
            self.status = status
        if xs is None:
            return None
        u = np.clip(xs[:-T0.size].reshape(self.N, self.nu), lbu, ubu)  # (IPOPT relaxes bounds by ~1e-8)
        T = np.maximum(xs[-T0.size:], 0.0)  # (a leg of no length comes back as −5e-10 s)
        return {"u": u, "dt": np.concatenate([np.full(int(n), T[j] / int(n)) for j, n in enumerate(self.legs)])}

    def _fastest(self, x0, lbx, ubx, legs: int) -> Optional[np.ndarray]:
        """The fastest schedule, then the least energy at its duration (or the fastest, where that
        second solve fails); None when the first does not converge."""
        xs = self._solve(x0, lbx, ubx, [1.0, 0.0, NO_CAP, NO_CAP])
        if xs is None:
            return None
        status = self.status
        least = self._solve(xs, lbx, ubx, [0.0, 1.0, float(np.sum(xs[-legs:])) * (1 + TIME_SLACK), NO_CAP])
        self.status = status
        return least if least is not None else xs

    def _solve(self, x0, lbx, ubx, p) -> Optional[np.ndarray]:
        sol = self.solver(x0=x0, p=p, lbx=lbx, ubx=ubx, lbg=self.lbg, ubg=self.ubg)
        self.status = self.solver.stats()["return_status"]
        if self.status not in ("Solve_Succeeded", "Solved_To_Acceptable_Level"):
            return None
        return np.asarray(sol["x"], float).ravel()
