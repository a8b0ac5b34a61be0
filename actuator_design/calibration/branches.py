"""Stable equilibria on the branch a measurement lies on, with exact output sensitivities.

Only stable equilibria are accepted (THEORY §7): an unstable one is left along its unstable mode
in the direction that brings the model closer to the measurement. Stability is judged by the
package's one rule (THEORY §7), certified cheaply by a Cholesky factor of M^-1/2 H_r M^-1/2 − τ I
before any eigen-analysis; the implicit-function sensitivities are dz/dq = −H_r⁻¹ ∂(∇_r Ê)/∂q.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, List, Optional, Sequence, Tuple

import casadi as ca
import numpy as np
import scipy.linalg

from actuator_design.equilibrium.solver import EquilibriumSolver
from actuator_design.reduced.linalg import mass_scaled
from actuator_design.reduced.stability import certified_stable

__all__ = ["Verdict", "STABLE", "BranchSelector"]


@dataclass(frozen=True)
class Verdict:
    """Stability of an equilibrium: stable, marginal, Morse index, unstable mode (or None)."""

    stable: bool = True
    marginal: bool = False
    morse_index: int = 0
    eigenvector: Optional[np.ndarray] = None

    @property
    def accepted(self) -> bool:
        """Stable or marginally stable (a measurement can lie there)."""
        return bool(self.stable or self.marginal)


STABLE = Verdict()

#: misfit(outputs) → weighted squared distance of model outputs from a measurement.
Misfit = Callable[[np.ndarray], float]


class _DenseCall:
    """A CasADi function evaluated straight into preallocated numpy arrays.

    Converting CasADi's sparse results to numpy costs more than evaluating them (a fit makes
    one such call per condition and evaluation, 10⁵–10⁶ in all): the outputs are densified once
    and written column-major into fixed buffers. The returned arrays are views of those buffers,
    valid until the next call.
    """

    def __init__(self, f: ca.Function):
        self._buffer, self._evaluate = f.buffer()
        self._args = [np.zeros(f.nnz_in(i)) for i in range(f.n_in())]
        self._shapes = [(f.size1_out(j), f.size2_out(j)) for j in range(f.n_out())]
        self._res = [np.zeros(a * b) for a, b in self._shapes]
        for i, a in enumerate(self._args):
            self._buffer.set_arg(i, memoryview(a))
        for j, r in enumerate(self._res):
            self._buffer.set_res(j, memoryview(r))

    def __call__(self, *args) -> List[np.ndarray]:
        for buf, a in zip(self._args, args):
            buf[:] = a
        self._evaluate()
        return [r.reshape(shape, order="F") for r, shape in zip(self._res, self._shapes)]


class BranchSelector:
    """Equilibria of one scene structure, their stability, outputs and sensitivities.

    Parameters
    ----------
    solver : EquilibriumSolver
        Built for the fit's scene structure.
    slot_index : ndarray of int, shape (n_slots,)
        Positions in the NLP parameter vector P of the slots the fit changes.
    components : sequence of int
        Component of the tip vector (θ(1), x(1), y(1)) of each measured output.
    out_scale : ndarray, shape (n_out,)
        Factor from the dimensionless tip component to the output's SI value (ℓ for lengths of a
        physical scene, else 1).
    """

    def __init__(self, solver: EquilibriumSolver, slot_index: np.ndarray, components: Sequence[int],
                 out_scale: np.ndarray):
        self.solver = solver
        self.comp = list(components)
        self.out_scale = np.asarray(out_scale, float)
        layout = solver.layout
        de = solver.discrete
        z = de.z
        zr, P, Er, gr = solver.reduced_energy
        zfull = ca.vertcat(P[layout.slices["theta0"]], zr)
        Hr = ca.hessian(Er, zr)[0]
        tip = ca.substitute(ca.vertcat(*de.tip), z, zfull)
        slots = [int(i) for i in slot_index]
        # only the slot columns of ∂(∇Ê)/∂P and ∂T/∂P are needed (P also holds per-node fields)
        dense = ca.densify
        self.f_state = _DenseCall(ca.Function("fit_state", [zr, P], [dense(Hr), dense(tip)]))
        self.inv_sqrt_mass = 1.0 / np.sqrt(np.asarray(solver.transcription.mass[1:], float))
        sens = [Hr, tip, ca.jacobian(gr, P)[:, slots], ca.jacobian(tip, zr),
                ca.jacobian(tip, P)[:, slots]]
        self.f_sens = _DenseCall(ca.Function("fit_sens", [zr, P], [dense(a) for a in sens]))
        self.theta0_index = layout.slices["theta0"].start
        self.n_nodes = solver.transcription.nodes.size

    # -- pieces ---------------------------------------------------------------------------------
    def outputs(self, tip: np.ndarray) -> np.ndarray:
        """Measured outputs (SI) from the tip vector (θ(1), x(1), y(1)), shape (n_out,)."""
        return np.asarray(tip, float).ravel()[self.comp] * self.out_scale

    def straight(self, P: np.ndarray) -> np.ndarray:
        """The straight rod at the clamp angle, shape (n_nodes,)."""
        return np.full(self.n_nodes, P[self.theta0_index])

    def converge(self, z0: np.ndarray, P: np.ndarray, minimise: bool = False):
        """Newton from ``z0`` (IPOPT if it fails); ``minimise``: IPOPT first, which descends the
        energy (Newton converges to any nearby stationary point, e.g. back to a saddle)."""
        s = self.solver
        if not minimise:
            raw = s.solve_newton(z0, P)
            if raw.converged:
                return raw
        raw = s.solve_ipopt(z0, P)
        if np.all(np.isfinite(raw.z)):
            polish = s.solve_newton(raw.z, P, max_iter=8)
            if polish.converged:
                return polish
        return raw

    def verdict(self, z: np.ndarray, P: np.ndarray) -> Tuple[Verdict, np.ndarray]:
        """(stability verdict, outputs) at an equilibrium ``z``, by the package's one stability rule
        (THEORY §7; :func:`~actuator_design.reduced.stability.classify_spectrum`): a Cholesky factor of
        M^-1/2 H_r M^-1/2 − τ I certifies "stable" (:func:`~actuator_design.reduced.stability.certified_stable`);
        otherwise the eigen-analysis decides (Morse index, marginal, unstable mode)."""
        Hr, tip = self.f_state(z[1:], P)
        out = self.outputs(tip)
        if certified_stable(mass_scaled(Hr, self.inv_sqrt_mass)):
            return STABLE, out
        v = self.solver.stability(z, P)
        return Verdict(bool(v.stable), bool(v.marginal), int(v.morse_index), v.eigenvector), out

    def stable_equilibrium(self, z0: np.ndarray, P: np.ndarray, misfit: Misfit):
        """Converge from ``z0``; leave an unstable equilibrium along its unstable mode in the
        direction that brings the model closer to the measurement.

        Returns
        -------
        z : ndarray, shape (n_nodes,)
        converged : bool
        verdict : Verdict or None
        outputs : ndarray, shape (n_out,), or None
        """
        raw = self.converge(z0, P)
        if not raw.converged:
            return raw.z, False, None, None
        return self.leave_unstable(raw.z, P, misfit)

    def leave_unstable(self, z: np.ndarray, P: np.ndarray, misfit: Misfit):
        """From an equilibrium ``z``: itself if stable, else the stable equilibrium reached by
        leaving along the unstable mode towards the measurement (as :meth:`stable_equilibrium`)."""
        verdict, out = self.verdict(z, P)
        for _ in range(3):
            if verdict.accepted:
                break
            v = verdict.eigenvector
            trials = [z + a * v for a in (0.2, -0.2)]
            trials.sort(key=lambda zz: misfit(self.verdict_free_outputs(zz, P)))
            for start in trials:
                trial = self.converge(start, P, minimise=True)
                if trial.converged:
                    z = trial.z
                    verdict, out = self.verdict(z, P)
                    break
            else:
                break
        return z, True, verdict, out

    def verdict_free_outputs(self, z: np.ndarray, P: np.ndarray) -> np.ndarray:
        """Outputs of any state ``z`` (not necessarily an equilibrium), shape (n_out,)."""
        return self.outputs(np.array([float(t) for t in self.solver.f_tip(z, P)]))

    def best(self, starts: List[np.ndarray], P: np.ndarray, misfit: Misfit, incumbent=None):
        """The accepted (stable) equilibrium closest to the measurement over ``starts``.

        Starts that coincide (to 1e-12), or that converge to an equilibrium already reached (to
        1e-10), are followed once. ``incumbent``: a previous return value to
        improve on. Returns ``(rank, z, verdict, outputs)`` with rank = (unstable, misfit), or
        None when no start converged; an unstable equilibrium wins only if no stable one exists.
        """
        best, tried, reached = incumbent, [], []
        for z0 in starts:
            if any(np.max(np.abs(z0 - t)) <= 1e-12 for t in tried):
                continue
            tried.append(z0)
            raw = self.converge(z0, P)
            # a start that reaches an equilibrium already reached leads where that one led
            if not raw.converged or any(np.max(np.abs(raw.z - r)) <= 1e-10 for r in reached):
                continue
            reached.append(raw.z)
            z, _, verdict, out = self.leave_unstable(raw.z, P, misfit)
            rank = (not verdict.accepted, misfit(out))
            if best is None or rank < best[0]:
                best = (rank, z, verdict, out)
        return best

    def stable_sensitivity(self, z: np.ndarray, P: np.ndarray, dq: np.ndarray):
        """:meth:`sensitivity` at an equilibrium a Cholesky factor of H_r proves to have Morse index 0
        (accepted: stable or marginal, :attr:`Verdict.accepted`), or None when H_r is not positive
        definite (the caller then runs the full branch selection).

        Returns
        -------
        outputs : ndarray, shape (n_out,)
        jacobian : ndarray, shape (n_out, k)
        dz_dtheta : ndarray, shape (n_nodes − 1, k)
            Sensitivity of the free nodes to the fitted parameters (natural units).
        """
        Hr, tip, Gq, Tz, Tq = self.f_sens(z[1:], P)
        try:
            factor = scipy.linalg.cho_factor(Hr, check_finite=False)
        except (np.linalg.LinAlgError, ValueError):
            return None
        dz = -scipy.linalg.cho_solve(factor, Gq, check_finite=False)
        dtip_dq = Tz @ dz + Tq
        return self.outputs(tip), (dtip_dq[self.comp] * self.out_scale[:, None]) @ dq, dz @ dq

    def sensitivity(self, z: np.ndarray, P: np.ndarray, dq: np.ndarray):
        """Outputs and d(outputs)/dθ by the implicit function theorem, at an equilibrium ``z``.

        Parameters
        ----------
        z : ndarray, shape (n_nodes,)
        P : ndarray, shape (n_P,)
            NLP parameter vector.
        dq : ndarray, shape (n_slots, k)
            d(slots)/dθ of the map from fitted parameters to the NLP slots.

        Returns
        -------
        outputs : ndarray, shape (n_out,), SI
        jacobian : ndarray, shape (n_out, k), SI per natural unit of θ
        """
        Hr, tip, Gq, Tz, Tq = self.f_sens(z[1:], P)
        try:
            dz = -scipy.linalg.cho_solve(scipy.linalg.cho_factor(Hr), Gq)
        except (np.linalg.LinAlgError, ValueError):
            try:
                dz = -scipy.linalg.solve(Hr, Gq, assume_a="sym")
            except (np.linalg.LinAlgError, ValueError):
                dz = -np.linalg.lstsq(Hr, Gq, rcond=None)[0]
        dtip_dq = Tz @ dz + Tq
        return self.outputs(tip), (dtip_dq[self.comp] * self.out_scale[:, None]) @ dq
