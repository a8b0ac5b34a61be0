"""A continuation problem along one loading-schedule segment: several lens parameters move at once.

Between two schedule points a and b the named parameters move on the straight segment
p(λ) = p_a + λ (p_b − p_a), λ ∈ [0, 1]; values tied to them by the parameter lens move too
(setting the field magnitude h scales h_pos ∝ H: THEORY §5, :func:`actuator_design.physics.parameters.apply_values`).
:class:`LensSegment` gives all of them and their exact λ-derivatives; :class:`SegmentProblem` is
the reduced system G(u, λ) = g(u, p(λ)) = 0 with G_λ = Σ_i p_i'(λ) ∂g/∂p_i (chain rule, no finite
differences), plugged into :func:`~.engine.continuation` and :func:`~actuator_design.reduced.fold.locate_fold`
like :class:`~.problem.BifurcationProblem`.
"""
from __future__ import annotations

import math
from typing import Dict, List, Sequence, Tuple

import numpy as np

from actuator_design.continuation.problem import BifurcationProblem
from actuator_design.model.scene import Scene
from actuator_design.physics import parameters as lens
from actuator_design.reduced.system import ReducedSystem

__all__ = ["LensSegment", "SegmentProblem", "followers"]

_WHAT = "path parameter"
_TINY = np.finfo(float).tiny


def followers(base: Scene, names: Sequence[str], rows: np.ndarray) -> List[str]:
    """Lens parameters of other slots than ``names``' that change when the schedule ``rows``
    (n_rows, len(names)) is applied to ``base`` through the lens (e.g. ``h_pos`` when ``h`` is
    ramped in a dipole field), in lens order."""
    scenes = [lens.apply_values(base, dict(zip(names, map(float, row))), _WHAT) for row in rows]
    slots = {lens.parameter(n, _WHAT).slot for n in names}
    out = []
    for q in lens.parameters().values():
        # only values the lens scales with the field can follow; not a scheduled slot (p and fy)
        if not q.field_power or q.slot in slots:
            continue
        before = q.get(base)
        if any(q.get(sc) != before for sc in scenes):
            out.append(q.name)
    return out


class LensSegment:
    """The segment λ ↦ p(λ) of the scheduled parameters and the lens values that follow them.

    Parameters
    ----------
    base : Scene
        The path's scene (its values not scheduled stay fixed; followers scale from it).
    names : sequence of str
        Scheduled lens parameter names.
    va, vb : ndarray, shape (len(names),)
        Values at λ = 0 and λ = 1 (dimensionless, angles in rad).
    follow : sequence of str
        Lens parameters that follow the field magnitude (:func:`followers`); each scales as
        (m(λ)/m_base)^(power_q/power_m), m the scheduled magnitude (``h`` or ``h2``), as the lens'
        field-scaling rule sets it (checked against :func:`actuator_design.physics.parameters.apply_values`
        on construction).

    Notes
    -----
    A segment of a magnitude m ∝ H^f with f > 1 (``h2`` = h²) that starts or ends at zero field and
    has a follower whose energy is of a lower power in the field (h_r ∝ H = m^(1/f) enters linearly,
    THEORY §9; h_pos² ∝ m does not count) moves linearly in the field instead: m(λ) =
    (m_a^(1/f) + λ (m_b^(1/f) − m_a^(1/f)))^f, the other scheduled values linearly in λ, so that every
    value and the rod's state are smooth in λ (linearly in h2, h_r and the state would leave zero
    field with an infinite slope and no continuation could start). The segment is then straight in
    (H, the other values), its ends are the schedule's points, and :meth:`values` gives m(λ).

    Attributes
    ----------
    system_names : tuple of str
        ``names`` then ``follow``: the parameters of the reduced system.
    """

    def __init__(self, base: Scene, names: Sequence[str], va, vb, follow: Sequence[str] = ()):
        self.base, self.names = base, list(names)
        self.va, self.vb = np.asarray(va, float), np.asarray(vb, float)
        self.system_names = tuple(self.names) + tuple(follow)
        self._pars = [lens.parameter(n, _WHAT) for n in self.names]
        self._lower = np.array([p.lower for p in self._pars])
        self._upper = np.array([p.upper for p in self._pars])
        self._laws = []  # (scheduled index of the magnitude, base value, exponent) per follower
        mags = [i for i, p in enumerate(self._pars) if p.field_magnitude]
        for q in map(lens.parameter, follow):
            if not mags:
                raise RuntimeError(f"{q.name} follows the schedule but no field magnitude is scheduled")
            m, r = self._pars[mags[0]], q.field_power / self._pars[mags[0]].field_power
            if m.get(base) > 0:
                c = q.get(base) / m.get(base) ** r
            else:  # from zero field: the physical scene's groups per field (q = t_q H^f, h = t_h H)
                table = lens.per_field(base)
                c = table[q.name] / table["h"] ** q.field_power
            self._laws.append((mags[0], c, r))
        # (index, f) of a magnitude followed in the field H itself (class notes), else None
        self._in_field = None
        # (a follower's energy is ∝ its value, or its square for a "squared" residual: h_pos²)
        energy_powers = [r * (2.0 if lens.parameter(q).residual == "squared" else 1.0)
                         for q, (_, _, r) in zip(follow, self._laws)]
        if self._laws and any(e < 1.0 for e in energy_powers):
            i = mags[0]
            f = float(self._pars[i].field_power)
            if f > 1.0 and min(self.va[i], self.vb[i]) == 0.0:
                self._in_field = (i, f)
        for lam in ((0.0, 0.5, 1.0) if self._laws else ()):  # the closed form is the lens' rule: check it
            got, sc = self.point(lam)[0], self.scene(lam)
            for name, value in zip(self.system_names, got):
                ref = lens.parameter(name).get(sc)
                if abs(value - ref) > 1e-12 * max(1.0, abs(ref)):
                    raise RuntimeError(f"{name}: the segment gives {value!r}, the parameter lens {ref!r}")

    @property
    def span(self) -> float:
        """max(1, the largest change of a scheduled value over the segment), in its own units: a
        step of δ/span in λ moves no scheduled value by more than δ."""
        return float(max(1.0, np.max(np.abs(self.vb - self.va), initial=0.0)))

    def values(self, lam: float) -> Dict[str, float]:
        """The scheduled values at λ, each kept in its parameter's range (λ may pass an end by
        rounding)."""
        v = self._scheduled(lam)[0]
        return {p.name: min(max(float(x), p.lower), p.upper) for p, x in zip(self._pars, v)}

    def _scheduled(self, lam: float) -> Tuple[np.ndarray, np.ndarray, float, float]:
        """(values, slopes) of the scheduled parameters at λ, unclipped, and for a magnitude followed
        in the field (class notes) x = m^(1/f) and dx/dλ (else nan, nan)."""
        v, slope = self.va + lam * (self.vb - self.va), self.vb - self.va
        if self._in_field is None:
            return v, slope, math.nan, math.nan
        i, f = self._in_field
        a, b = self.va[i] ** (1.0 / f), self.vb[i] ** (1.0 / f)
        x, dx = min(max(a + lam * (b - a), min(a, b)), max(a, b)), b - a  # (no field beyond the ends)
        v, slope = v.copy(), slope.copy()
        v[i] = self.va[i] if lam == 0.0 else self.vb[i] if lam == 1.0 else x ** f  # the ends exactly
        slope[i] = f * x ** (f - 1.0) * dx
        return v, slope, x, dx

    def scene(self, lam: float) -> Scene:
        """The scene at λ (through the lens, so every follower is set by its rule)."""
        return lens.apply_values(self.base, self.values(lam), _WHAT)

    def point(self, lam: float) -> Tuple[np.ndarray, np.ndarray]:
        """(p(λ), dp/dλ), each of shape (len(system_names),): scheduled values, then followers."""
        sched, slope, x, dx = self._scheduled(lam)
        sched = np.clip(sched, self._lower, self._upper)
        if not self._laws:
            return sched, slope
        p, dp = [*sched], [*slope]
        for i, c, r in self._laws:
            m, dm = sched[i], slope[i]
            value = c * m ** r
            if value == 0.0 and c != 0.0:  # the lens keeps the smallest normal float (term kept)
                value = math.copysign(_TINY, c)
            p.append(value)
            if self._in_field is not None and i == self._in_field[0]:  # q = c x^(f r): smooth in x
                e = self._in_field[1] * r
                dp.append(c * e * max(x, 0.0) ** (e - 1.0) * dx if e != 1.0 else c * dx)
            else:
                dp.append(c * r * max(m, _TINY) ** (r - 1.0) * dm)
        return np.array(p), np.array(dp)

    def params(self, lam: float, P: np.ndarray, layout) -> np.ndarray:
        """The full NLP parameter vector at λ: ``P`` with every system parameter's slot set
        through its lens transform (``h2`` → √)."""
        out = np.array(P, float)
        for name, value in zip(self.system_names, self.point(lam)[0]):
            par = lens.parameter(name)
            out[layout.slices[par.slot]] = par.to_slot(value)
        return out


class _SegmentEvaluator:
    """(u, λ) -> (g, H, G_λ) of a multi-parameter system evaluator along a segment (chain rule)."""

    def __init__(self, inner, point):
        self.inner, self.point = inner, point
        self.gl = np.zeros_like(inner.g)

    def __call__(self, u, lam):
        p, dp = self.point(lam)
        g, H, gl = self.inner(u, p)
        self.gl = gl @ dp if gl.ndim == 2 else gl * dp[0]
        return g, H, self.gl

    @property
    def g(self):
        return self.inner.g

    @property
    def H(self):
        return self.inner.H

    @property
    def calls(self) -> int:
        return self.inner.calls


class SegmentProblem(BifurcationProblem):
    """G(u, λ) = 0 along a :class:`LensSegment`; λ ∈ [0, 1] is the segment coordinate.

    Parameters
    ----------
    system : ReducedSystem
        Built in ``segment.system_names`` (cached per path: every segment of a schedule shares it).
    P : ndarray, shape (n_P,)
        NLP parameters of the values that do not move (the moving slots are ignored).
    segment : LensSegment
    """

    def __init__(self, system: ReducedSystem, P: np.ndarray, segment: LensSegment):
        if tuple(system.names) != segment.system_names:
            raise ValueError(f"the system's parameters {system.names} are not the segment's "
                             f"{segment.system_names}")
        layout = system.solver.layout
        super().__init__(system, P, theta0=float(np.asarray(P)[layout.slices["theta0"]][0]))
        self.segment, self.layout = segment, layout
        self.lens = "lambda"
        self.ev = _SegmentEvaluator(self.ev, segment.point)
        self._theta0 = (segment.system_names.index("theta0") if "theta0" in segment.system_names
                        else None)

    def full(self, u: np.ndarray, lam: float) -> np.ndarray:
        """Node vector z = (θ0(λ), u), shape (n + 1,)."""
        th0 = self.theta0 if self._theta0 is None else float(self.segment.point(lam)[0][self._theta0])
        return np.concatenate(([th0], u))

    def tip(self, x: np.ndarray):
        """(θ(1), x(1), y(1)) at x = (u, λ)."""
        p = self.segment.point(x[self.n])[0]
        t = np.asarray(self.system.f_tip(x[:self.n], p, self.P)[0], float).ravel()
        return float(t[0]), float(t[1]), float(t[2])

    def params(self, lam: float) -> np.ndarray:
        """The full NLP parameter vector at λ."""
        return self.segment.params(lam, self.P, self.layout)
