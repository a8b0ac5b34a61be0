"""The result of an equilibrium solve: status, shape, tip, energy, reactions, stability.

Modelled on scipy's ``solve_bvp`` result: it never hides non-convergence (``success``, ``status``,
``message``), and its shape can be evaluated densely between the solver's nodes.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Callable, Dict, Optional

import numpy as np

from actuator_design.equilibrium.options import SolverOptions
from actuator_design.io.display import degrees, number
from actuator_design.model.scene import Scene
from actuator_design.physics import parameters as lens
from actuator_design.physics.registration import describe_scales
from actuator_design.physics.registry import describe_groups, registered_terms

__all__ = ["EquilibriumResult"]


@dataclass
class EquilibriumResult:
    """An equilibrium of a scene (dimensionless, THEORY §5; ``scales`` converts to SI).

    Attributes
    ----------
    success : bool
        The solver converged to a stationary point (stability is separate: see ``stable``).
    status : str
        ``"converged"``, ``"not_converged"`` or the solver's own status word.
    message : str
        Human-readable account, including any saddle escape.
    s, theta : ndarray, shape (n_nodes,)
        Arc length (units of ℓ) and tangent angle θ (rad) at the solver's nodes.
    x, y : ndarray, shape (n_nodes,)
        Centre-line positions at the nodes, units of ℓ, clamp at the origin.
    tip : dict
        ``x``, ``y`` (units of ℓ) and ``angle`` = θ(1) (rad).
    energy : float
        Discrete energy Ê, units of B0/ℓ.
    clamp_force : ndarray, shape (2,)
        Force the clamp exerts on the rod, units of B0/ℓ².
    clamp_moment : float
        Moment the clamp exerts on the rod, units of B0/ℓ (counter-clockwise positive).
    el_residual : float
        max over s of |moment balance of the free part [s, 1]| (units of B0/ℓ): the integrated
        Euler–Lagrange equation evaluated on the dense solution.
    stationarity : float
        max_i |∂Ê/∂θ_i| / m_i of the discrete problem.
    eigenvalues : ndarray
        Smallest eigenvalues of the reduced Hessian (against the L² mass), ascending.
    morse_index : int
    stable : bool
    escaped_saddle : bool
        True when the solver first stopped at an unstable equilibrium and was perturbed along its
        unstable eigenvector to reach this one.
    stats : dict
        Iterations, times (s), build/cached flags, method used.
    """

    def __repr__(self) -> str:
        """One line: status, tip (units of ℓ, rad), stability (the dataclass's repr prints arrays)."""
        tip = getattr(self, "tip", None) or {}
        return (f"EquilibriumResult(status={self.status!r}, success={self.success}, "
                f"tip=(x={tip.get('x', float('nan')):.6g}, y={tip.get('y', float('nan')):.6g}, "
                f"angle={tip.get('angle', float('nan')):.6g}), stable={self.stable}, "
                f"morse_index={self.morse_index}, energy={self.energy:.8g})")


    success: bool
    status: str
    message: str
    scene: Scene
    options: SolverOptions
    s: np.ndarray
    theta: np.ndarray
    tip: Dict[str, float]
    energy: float
    stationarity: float
    eigenvalues: np.ndarray
    morse_index: int
    stable: bool
    marginal: bool = False
    escaped_saddle: bool = False
    stats: Dict[str, object] = field(default_factory=dict)
    z: Optional[np.ndarray] = None  # raw node vector (warm starts)
    #: a-posteriori estimate of the tip error (rod lengths) when an accuracy was asked for
    error_estimate: Optional[float] = None
    #: the contact set of a scene with obstacles (:mod:`actuator_design.contact.equilibrium`), else None
    contact: Optional[dict] = None
    #: callables filled by the solver; the diagnostics they compute are evaluated on first access
    _dense: Optional[Callable] = field(default=None, repr=False)
    _balance: Optional[Callable] = field(default=None, repr=False)
    _intersects: Optional[Callable] = field(default=None, repr=False)
    #: () -> θ'(0) from the transcription's interpolant, when the solver gave it
    _clamp_curvature: Optional[Callable] = field(default=None, repr=False)

    def _path_text(self) -> str:
        """The loading path from rest whose state the solver started from, when it did (the path's
        Newton steps, not the solver's iterations, then did most of the work)."""
        path = self.stats.get("from_rest") or {}
        if not path.get("steps") or path.get("solved_from") != "path":
            return ""  # (the straight-rod start was solved: the message says why)
        steps = int(path["steps"])
        return (f", from the state a path from rest of {steps} step{'s' * (steps != 1)} reached "
                f"({path.get('newton_solves', '?')} Newton solves, {1e3 * float(path.get('time_s', 0.0)):.2f} ms)")

    # -- lazily evaluated diagnostics ------------------------------------------------------------
    @cached_property
    def _nodes_xy(self):
        _, _, x, y = self._dense(self.s)
        return x, y

    @property
    def x(self) -> np.ndarray:
        return self._nodes_xy[0]

    @property
    def y(self) -> np.ndarray:
        return self._nodes_xy[1]

    @cached_property
    def _reaction(self):
        return self._balance()

    @property
    def clamp_force(self) -> np.ndarray:
        return self._reaction[0]

    @property
    def clamp_moment(self) -> float:
        return self._reaction[1]

    @property
    def el_residual(self) -> float:
        return self._reaction[2]

    @cached_property
    def self_intersecting(self) -> bool:
        """Whether the centre line crosses itself. A curve whose tangent angles span less than π
        is a graph over the direction of their mean, hence cannot (checked first, from the nodes,
        with a margin for the interpolant between them)."""
        th = np.asarray(self.theta, float)
        if th.size and np.all(np.isfinite(th)) and np.ptp(th) < np.pi - 0.05:
            return False
        return bool(self._intersects(self.x, self.y))

    # -- dense evaluation ----------------------------------------------------------------------
    def evaluate(self, s) -> Dict[str, np.ndarray]:
        """θ, θ', x, y at arbitrary arc lengths ``s`` ∈ [0, 1] (interpolant of the transcription)."""
        theta, dtheta, x, y = self._dense(np.asarray(s, float))
        return {"s": np.asarray(s, float), "theta": theta, "dtheta": dtheta, "x": x, "y": y}

    @property
    def gamma(self) -> float:
        """θ'(0), the clamp curvature (units of 1/ℓ)."""
        if self._clamp_curvature is not None:  # no positions needed
            return float(self._clamp_curvature())
        return float(self.evaluate(np.array([0.0]))["dtheta"][0])

    # -- conversions -----------------------------------------------------------------------------
    def physical(self) -> Optional[Dict[str, object]]:
        """Tip and reactions in SI units, or ``None`` for a dimensionless scene."""
        sc = self.scene.scales
        if sc is None:
            return None
        return {
            "tip_x_m": self.tip["x"] * sc.length,
            "tip_y_m": self.tip["y"] * sc.length,
            "tip_angle_rad": self.tip["angle"],
            "energy_J": self.energy * sc.moment,
            "clamp_force_N": (self.clamp_force * sc.force).tolist(),
            "clamp_moment_Nm": self.clamp_moment * sc.moment,
            "field_A_per_m": lens.applied_field(self.scene),  # of the groups, not the YAML's scale
        }

    #: the top-level keys of :meth:`to_dict`, in order
    DICT_KEYS = ("success", "status", "message", "stable", "morse_index", "marginal", "escaped_saddle",
                 "self_intersecting", "tip", "energy", "h", "phi", "p", "gamma", "clamp_reaction",
                 "el_residual", "error_estimate", "stationarity", "eigenvalues", "shape", "groups",
                 "scales", "physical", "units", "solver", "contact")

    def to_dict(self, include=None) -> Dict[str, object]:
        """The JSON contract of ``actuator-design solve --json`` (keys are stable; more may be added).

        Parameters
        ----------
        include : iterable of str, optional
            Only these top-level keys (of :attr:`DICT_KEYS`), in contract order: the diagnostics
            behind the others (shape, reactions, physical values) are not evaluated. Default all.
        """
        makers = {
            "success": lambda: bool(self.success),
            "status": lambda: self.status,
            "message": lambda: self.message,
            "stable": lambda: bool(self.stable),
            "morse_index": lambda: int(self.morse_index),
            "marginal": lambda: bool(self.marginal),
            "escaped_saddle": lambda: bool(self.escaped_saddle),
            "self_intersecting": lambda: bool(self.self_intersecting),
            "tip": lambda: {k: float(v) for k, v in self.tip.items()},
            "energy": lambda: float(self.energy),
            "h": lambda: float(self.scene.h),
            "phi": lambda: float(self.scene.phi),
            "p": lambda: float(self.scene.p),
            "gamma": lambda: self.gamma,
            "clamp_reaction": lambda: {"force": [float(v) for v in self.clamp_force],
                                       "moment": float(self.clamp_moment)},
            "el_residual": lambda: float(self.el_residual),
            "error_estimate": lambda: None if self.error_estimate is None else float(self.error_estimate),
            "stationarity": lambda: float(self.stationarity),
            "eigenvalues": lambda: [float(v) for v in self.eigenvalues],
            "contact": lambda: self.contact,
            "shape": lambda: {"s": self.s.tolist(), "x": self.x.tolist(), "y": self.y.tolist(),
                              "theta": self.theta.tolist()},
            "groups": lambda: describe_groups(self.scene),
            "scales": lambda: describe_scales(self.scene.scales),
            "physical": self.physical,
            "units": lambda: {"length": "rod length", "energy": "B0/l", "force": "B0/l^2",
                              "moment": "B0/l", "angle": "rad"},
            "solver": lambda: {**self.options.as_dict(), **{k: v for k, v in self.stats.items()}},
        }
        wanted = set(self.DICT_KEYS if include is None else include)
        return {k: makers[k]() for k in self.DICT_KEYS if k in wanted}

    def _groups_text(self) -> str:
        """h, then φ (a uniform field) or h_pos (a non-uniform one), h_r (a remanent rod), p."""
        sc = self.scene
        parts = [f"h = {number(sc.h)}"]
        if sc.field is None or sc.field.is_uniform:
            parts.append(f"phi = {degrees(sc.phi)} deg")
        # the groups the terms show (h_pos of a non-uniform field, h_r of a remanent rod), p last and always
        parts += [f"{name} = {number(value)}" for cls in registered_terms()
                  for name, value in cls.summary(sc).groups if name != "p"]
        return ", ".join(parts + [f"p = {number(sc.p)}"])

    def summary(self) -> str:
        """A readable multi-line summary."""
        lines = [
            f"{self.scene.name}",
            f"  status      : {self.status} ({'success' if self.success else 'FAILED'}) — {self.message}",
            f"  groups      : {self._groups_text()}",
            *([f"  field       : {self.scene.field.describe()}"] if hasattr(self.scene.field, "describe") else []),
            *([f"  terms       : " + "; ".join(f"{t.name}: " + ", ".join(f"{k} = {number(v)}" for k, v in t.values)
                                             for t in self.scene.extra_terms)] if self.scene.extra_terms else []),
            f"  tip         : x = {number(self.tip['x'], '.10f')}, y = {number(self.tip['y'], '.10f')}, "
            f"angle = {number(self.tip['angle'], '.10f')} rad ({degrees(self.tip['angle'], '.6f')} deg)  [units of l]",
            f"  energy      : {number(self.energy, '.12g')}  [B0/l]",
            f"  clamp       : force = ({number(self.clamp_force[0])}, {number(self.clamp_force[1])}) [B0/l^2], "
            f"moment = {number(self.clamp_moment)} [B0/l]",
            f"  stability   : {'STABLE' if self.stable else 'UNSTABLE'} (Morse index {self.morse_index}; "
            f"smallest eigenvalues {', '.join(f'{v:.6g}' for v in self.eigenvalues)})",
            f"  accuracy    : EL residual {self.el_residual:.2e}, stationarity {self.stationarity:.2e}"
            + ("" if self.error_estimate is None else f", estimated tip error {self.error_estimate:.2e} [l]"),
            f"  solver      : {self.options.transcription} (elements {self.options.elements}"
            + (f" + {self.options.extra_elements} graded or at contacts" if self.options.extra_elements else "")
            + (f", degree {self.options.degree}" if self.options.transcription == "lgl" else "")
            + f"), {self.stats.get('method', '')}, {self.stats.get('iterations', '?')} iterations, "
            f"{1e3 * float(self.stats.get('solve_time_s', 0)):.2f} ms" + self._path_text(),
        ]
        if self.escaped_saddle:
            lines.append("  note        : the solver first stopped at an unstable equilibrium and was "
                         "perturbed along its unstable mode to reach this stable one")
        if self.contact is not None:
            c = self.contact
            # a self-contact once (its end of lower arc length), against the other end
            strong = [p for p in c["points"] if not p["weak"] and not (p.get("self") and p["s"] > p["partner_s"])]

            def what(p):
                if p.get("self"):
                    return f"against the rod at s = {p['partner_s']:.4g}"
                return "tip" if p["s"] == 1.0 else "obstacle " + str(p["obstacle"] + 1)
            where = ", ".join(f"s = {p['s']:.4g} ({what(p)})" for p in strong[:4]) + (", ..." if len(strong) > 4 else "")
            lines.append(f"  contact     : {len(strong)} contact(s){': ' + where if strong else ''}; "
                         f"total contact force ({number(c['total_force'][0])}, {number(c['total_force'][1])}) "
                         f"[B0/l^2]" + (f" = ({number(c['total_force_N'][0], '.4g')}, "
                                        f"{number(c['total_force_N'][1], '.4g')}) N" if "total_force_N" in c else "")
                         + (f"; {c['weakly_active']} weakly active (no force at the gap)"
                                        if c["weakly_active"] else ""))
        if self.self_intersecting:
            lines.append("  warning     : the shape intersects itself")
        phys = self.physical()
        if phys:
            lines.append(f"  physical    : tip = ({number(1e3 * phys['tip_x_m'])}, {number(1e3 * phys['tip_y_m'])}) mm, "
                         f"clamp force = ({number(phys['clamp_force_N'][0], '.4g')}, "
                         f"{number(phys['clamp_force_N'][1], '.4g')}) N, "
                         f"clamp moment = {number(phys['clamp_moment_Nm'], '.4g')} N m, field scale H0 = "
                         f"{phys['field_A_per_m']:.6g} A/m")
        return "\n".join(lines)
