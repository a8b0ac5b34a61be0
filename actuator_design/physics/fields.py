"""Applied fields ĥ(x, y), kept apart from their coupling to the rod (THEORY §3).

Each field evaluates its dimensionless direction-and-shape ĥ at rod positions as CasADi expressions,
so every gradient the solver needs (the field-gradient force on the rod included) is exact. The field
strength is not here: it is the scene's group ``h`` (THEORY §5).
"""
from __future__ import annotations

import math
from dataclasses import replace
from typing import Dict, Tuple

import casadi as ca
import numpy as np

from actuator_design.model.expressions import Expression
from actuator_design.model.scene import DipoleField, ExpressionField, SourceField, UniformField
from actuator_design.physics.harmonic import field_function
from actuator_design.physics.tesseral import interior_modes, tesseral_in_plane

__all__ = ["FieldModel", "field_model", "FieldCheckError", "check_current_free"]


class FieldCheckError(ValueError):
    """A user field is not the field of a current-free region (div or curl ≠ 0)."""


class FieldModel:
    """Symbolic evaluation of one kind of applied field.

    Attributes
    ----------
    params : tuple of str
        Names of the NLP parameters the field reads (e.g. ``("phi",)``).
    is_uniform : bool
        A uniform field needs no rod positions and builds no positional term.
    """

    params: Tuple[str, ...] = ()
    is_uniform = False

    def value(self, x, y, P: Dict[str, ca.SX]):
        """ĥ at positions ``x``, ``y`` (CasADi column vectors, units of ℓ) → (hx, hy)."""
        raise NotImplementedError

    def parameter_values(self, field) -> Dict[str, float]:
        return {}

    def default_values(self) -> Dict[str, float]:
        """Values :meth:`evaluate` and :func:`check_current_free` take for parameters not given."""
        return {}

    def jet(self, x, y, P: Dict[str, ca.SX]):
        """ĥ and its first and second derivatives at one point (scalar SX ``x``, ``y``).

        Returns
        -------
        h : SX (2,)
            (ĥ_x, ĥ_y).
        J : SX (2, 2)
            J[i, j] = ∂ĥ_i/∂r_j (units of 1/ℓ).
        T : list of two SX (2, 2)
            T[i][j, k] = ∂²ĥ_i/∂r_j∂r_k (units of 1/ℓ²).

        By automatic differentiation of :meth:`value`; fields with closed forms override it
        (the Newton kernels evaluate it at every quadrature point).
        """
        r = ca.SX.sym("r", 2)
        hx, hy = self.value(r[0], r[1], P)
        h = ca.vertcat(hx, hy)
        J = ca.jacobian(h, r)
        T = [ca.hessian(hx, r)[0], ca.hessian(hy, r)[0]]
        at = lambda e: ca.substitute(e, r, ca.vertcat(x, y))
        return at(h), at(J), [at(t) for t in T]

    def structure(self) -> tuple:
        """Hashable description of what is built symbolically (not the numbers)."""
        return (type(self).__name__,)

    def evaluate(self, x, y, values: Dict[str, float]) -> np.ndarray:
        """Numerical ĥ at arrays ``x``, ``y`` → array of shape (2, n)."""
        x = np.atleast_1d(np.asarray(x, float)).ravel()
        y = np.atleast_1d(np.asarray(y, float)).ravel()
        xs, ys = ca.SX.sym("x", x.size), ca.SX.sym("y", y.size)
        syms = {k: ca.SX.sym(k) for k in self.params}
        hx, hy = self.value(xs, ys, syms)
        f = ca.Function("h", [xs, ys] + list(syms.values()), [ca.vertcat(hx, hy)])
        values = {**self.default_values(), **values}
        out = f(x, y, *[values[k] for k in self.params])
        return np.asarray(out, float).reshape(2, x.size)


class UniformFieldModel(FieldModel):
    """ĥ = (cos φ, sin φ)."""

    params = ("phi",)
    is_uniform = True

    def value(self, x, y, P):
        return ca.cos(P["phi"]) * ca.DM.ones(x.shape), ca.sin(P["phi"]) * ca.DM.ones(x.shape)

    def parameter_values(self, field):
        return {"phi": field.phi}


class DipoleFieldModel(FieldModel):
    """Point dipole in the plane: ĥ(ρ) = [3 (m̂·ρ̂) ρ̂ − m̂] / |ρ|³, ρ = r − r0 (units of ℓ).

    The field scale H0 = |m| / (4π ℓ³) is folded into ``h``. Singular at the dipole: a rod that
    passes through it is outside the model (the solver reports non-convergence).
    """

    params = ("dipole_x0", "dipole_y0", "dipole_angle")

    def value(self, x, y, P):
        rx, ry = x - P["dipole_x0"], y - P["dipole_y0"]
        mx, my = ca.cos(P["dipole_angle"]), ca.sin(P["dipole_angle"])
        q = 1 / (rx * rx + ry * ry)  # 1/|ρ|²: the fewest operations, for the Newton kernels' sake
        k = q * ca.sqrt(q)  # 1/|ρ|³
        t = 3 * (mx * rx + my * ry) * q  # 3 (m̂·ρ̂)/|ρ|
        return (t * rx - mx) * k, (t * ry - my) * k

    def parameter_values(self, field):
        return {"dipole_x0": field.x0, "dipole_y0": field.y0, "dipole_angle": field.moment_angle}

    def jet(self, x, y, P):
        """Closed forms: ĥ = −∇ψ with ψ = (m̂·ρ)/|ρ|³, so that J = −∇∇ψ and T = −∇∇∇ψ are fully
        symmetric (q = 1/|ρ|², k_n = |ρ|⁻ⁿ, μ = m̂·ρ):

            ĥ_i    = 3 μ ρ_i k5 − m_i k3
            J_ij   = 3 (m_i ρ_j + m_j ρ_i + μ δ_ij) k5 − 15 μ ρ_i ρ_j k7
            T_ijk  = 3 (m_i δ_jk + m_j δ_ik + m_k δ_ij) k5
                     − 15 (m_i ρ_j ρ_k + m_j ρ_i ρ_k + m_k ρ_i ρ_j + μ (δ_ij ρ_k + δ_ik ρ_j + δ_jk ρ_i)) k7
                     + 105 μ ρ_i ρ_j ρ_k k9
        """
        X, Y = x - P["dipole_x0"], y - P["dipole_y0"]
        mx, my = ca.cos(P["dipole_angle"]), ca.sin(P["dipole_angle"])
        q = 1 / (X * X + Y * Y)
        k3 = q * ca.sqrt(q)
        k5 = k3 * q
        mu = mx * X + my * Y
        a, b = 3 * k5, 15 * k5 * q  # 3 k5, 15 k7
        A, B = mu * a, mu * b  # 3 μ k5, 15 μ k7
        C = 7 * B * q  # 105 μ k9
        XX, XY, YY = X * X, X * Y, Y * Y
        h = ca.vertcat(A * X - mx * k3, A * Y - my * k3)
        jxy = a * (mx * Y + my * X) - B * XY
        J = ca.blockcat([[2 * a * mx * X + A - B * XX, jxy], [jxy, 2 * a * my * Y + A - B * YY]])
        # the four distinct entries of the fully symmetric T
        txxx = 3 * (a * mx - b * mx * XX - B * X) + C * XX * X
        tyyy = 3 * (a * my - b * my * YY - B * Y) + C * YY * Y
        txxy = a * my - b * (2 * mx * XY + my * XX) - B * Y + C * XX * Y
        txyy = a * mx - b * (2 * my * XY + mx * YY) - B * X + C * XY * Y
        T = [ca.blockcat([[txxx, txxy], [txxy, txyy]]), ca.blockcat([[txxy, txyy], [txyy, tyyy]])]
        return h, J, T


class ExpressionFieldModel(FieldModel):
    """A user field (hx(x, y), hy(x, y)) from safe expressions (``actuator_design.model.expressions``)."""

    def __init__(self, field: ExpressionField):
        self.hx = Expression(field.hx, ("x", "y"))
        self.hy = Expression(field.hy, ("x", "y"))
        self.text = (field.hx, field.hy)

    def value(self, x, y, P):
        vals = {"x": x, "y": y}
        hx = self.hx.evaluate(vals, backend="casadi")
        hy = self.hy.evaluate(vals, backend="casadi")
        return hx + 0 * x, hy + 0 * y  # broadcast constants to the shape of x

    def structure(self):
        return (type(self).__name__,) + self.text


class SourceFieldModel(FieldModel):
    """Magnets and coils: ĥ = −Σ_k w_k ∇ψ_k of the fitted solid harmonics (:mod:`.harmonic`), exact
    derivatives by automatic differentiation; the fits are constants of the expression, the source
    weights w_k (``SourceField.weights``) NLP parameters ``source_weight_k``, and each source's rigid
    move (``SourceField.placements``) the parameters ``source_dx_k``, ``source_dy_k`` (units of ℓ) and
    ``source_turn_k`` (rad, about the source's own fitted centre c):

        ĥ_k(r) = Q(β) ĥ⁰_k(c + Qᵀ(β)(r − c − d)),    Q(β) the rotation by β,

    with ĥ⁰_k the field as fitted. It is written as r − d + (Q − I)ᵀ(...) so that at d = 0, β = 0 the
    field's values are those of the fit itself, to the last bit (its derivatives inside the NLP may
    differ at round-off: ~1e-20 in a Hessian).

    The coils of a calibration map share one expansion's geometry (centre, axis, radius): they form
    one rig, evaluated once as Σ_j (Σ_k w_k a_kj) ψ_j with the first coil's placement for the rig
    (eight coils: one basis instead of eight)."""

    def __init__(self, field: SourceField):
        self.terms = tuple(field.terms)
        n = len(self.terms)
        self.weight_params = tuple(f"source_weight_{k}" for k in range(n))
        self.placement_params = tuple((f"source_dx_{k}", f"source_dy_{k}", f"source_turn_{k}") for k in range(n))
        self.params = self.weight_params + tuple(name for names in self.placement_params for name in names)
        self._groups = _rigs(self.terms)
        self._f = [field_function((self.terms[g[0]],)) if len(g) == 1 else _rig_function([self.terms[k] for k in g])
                   for g in self._groups]

    def value(self, x, y, P):
        n = x.numel() if hasattr(x, "numel") else 1
        hx = hy = 0
        for group, f in zip(self._groups, self._f):
            k = group[0]
            c = self.terms[k].centre
            dx, dy, turn = (P.get(p, 0.0) for p in self.placement_params[k])
            cm1 = -2 * ca.sin(turn / 2) ** 2 if isinstance(turn, (ca.SX, ca.MX)) else -2 * math.sin(turn / 2) ** 2
            sn = ca.sin(turn) if isinstance(turn, (ca.SX, ca.MX)) else math.sin(turn)
            ux, uy = x - c[0] - dx, y - c[1] - dy  # r − c − d
            xl, yl = x - dx + cm1 * ux + sn * uy, y - dy - sn * ux + cm1 * uy  # c + Qᵀ(r − c − d)
            # callers evaluating the fitted field itself pass no weights
            w = [P.get(self.weight_params[j], 1.0) for j in group]
            extra = [] if len(group) == 1 else [ca.vertcat(*w)]
            if n == 1:
                fx, fy = f(xl, yl, *extra)
            else:
                fx, fy = f.map(n)(ca.reshape(xl, 1, n), ca.reshape(yl, 1, n), *extra)
                fx, fy = ca.reshape(fx, x.shape), ca.reshape(fy, x.shape)
            fx, fy = fx + cm1 * fx - sn * fy, fy + sn * fx + cm1 * fy  # Q ĥ⁰
            scale = w[0] if len(group) == 1 else 1.0
            hx, hy = hx + scale * fx, hy + scale * fy
        return hx, hy

    def evaluate(self, x, y, values: Dict[str, float]) -> np.ndarray:
        """Numerical ĥ at arrays ``x``, ``y`` → array of shape (2, n), by the fitted functions mapped
        over the points (the generic symbolic route inlines every term at every point: 5 s for a
        figure's grid beside a cuboid)."""
        x = ca.DM(np.atleast_1d(np.asarray(x, float)).ravel()).T
        y = ca.DM(np.atleast_1d(np.asarray(y, float)).ravel()).T
        values = {**self.default_values(), **values}
        hx, hy = self.value(x, y, {k: float(values[k]) for k in self.params})
        return np.vstack([np.asarray(hx, float).ravel(), np.asarray(hy, float).ravel()])

    def parameter_values(self, field):
        values = dict(zip(self.weight_params, field.source_weights()))
        for names, place in zip(self.placement_params, field.source_placements()):
            values.update(zip(names, place))
        return values

    def default_values(self):
        return {**dict.fromkeys(self.weight_params, 1.0),
                **{name: 0.0 for names in self.placement_params for name in names}}

    def structure(self):
        return (type(self).__name__,) + self.terms


def _rigs(terms) -> list:
    """Indices of ``terms`` in groups: the interior tesseral expansions (a calibration map's coils)
    sharing centre, axis and radius together, every other term alone."""
    groups, seen = [], {}
    for k, t in enumerate(terms):
        key = (t.centre, t.axis_angle, t.radius) if getattr(t, "modes", None) and t.kind == "interior" else None
        if key is not None and key in seen:
            groups[seen[key]].append(k)
            continue
        if key is not None:
            seen[key] = len(groups)
        groups.append([k])
    return groups


def _rig_function(terms) -> ca.Function:
    """(x, y, w) → ĥ of Σ_k w_k ĥ_k for expansions of one geometry (:func:`_rigs`), one basis."""
    x, y, w = ca.SX.sym("x"), ca.SX.sym("y"), ca.SX.sym("w", len(terms))
    modes = interior_modes(max(t.order for t in terms))
    combined = [0] * len(modes)
    index = {m: j for j, m in enumerate(modes)}
    for k, t in enumerate(terms):
        for mode, a in zip(t.modes, t.coefficients):
            combined[index[mode]] = combined[index[mode]] + w[k] * a
    psi = tesseral_in_plane(replace(terms[0], coefficients=tuple(combined), modes=modes), x, y)
    h = -ca.gradient(psi, ca.vertcat(x, y))
    return ca.Function("rig_field", [x, y, w], [h[0], h[1]])


def field_model(field) -> FieldModel:
    """The :class:`FieldModel` for a scene field dataclass."""
    if isinstance(field, UniformField):
        return UniformFieldModel()
    if isinstance(field, DipoleField):
        return DipoleFieldModel()
    if isinstance(field, ExpressionField):
        return ExpressionFieldModel(field)
    if isinstance(field, SourceField):
        return SourceFieldModel(field)
    raise TypeError(f"unknown field type {type(field).__name__}")


def check_current_free(model: FieldModel, values=None, radius: float = 1.0, n: int = 41,
                       rtol: float = 1e-6, name: str = "field") -> None:
    """Check numerically that a 2-D field is divergence- and curl-free (THEORY §3).

    Samples the disc of ``radius`` (units of ℓ) around the clamp — every point the inextensible rod
    can reach — on an ``n``×``n`` grid and evaluates the exact (symbolic) Jacobian of ĥ.

    Raises
    ------
    FieldCheckError
        Naming ``name``, the worst point and the size of div and curl relative to |∇ĥ|.
    """
    values = {**model.default_values(), **(values or {})}
    xs, ys = ca.SX.sym("x"), ca.SX.sym("y")
    syms = {k: ca.SX.sym(k) for k in model.params}
    hx, hy = model.value(xs, ys, syms)
    J = ca.jacobian(ca.vertcat(hx, hy), ca.vertcat(xs, ys))
    f = ca.Function("divcurl", [xs, ys] + list(syms.values()), [J[0, 0] + J[1, 1], J[1, 0] - J[0, 1], ca.norm_fro(J)])
    g = np.linspace(-radius, radius, n)
    X, Y = np.meshgrid(g, g)
    inside = X**2 + Y**2 <= radius**2 * (1 + 1e-12)
    X, Y = X[inside], Y[inside]
    fm = f.map(X.size)
    div, curl, norm = (np.asarray(v, float).ravel() for v in fm(X, Y, *[values.get(k, 0.0) for k in model.params]))
    if not np.all(np.isfinite(div) & np.isfinite(curl)):
        bad = int(np.argmax(~(np.isfinite(div) & np.isfinite(curl))))
        raise FieldCheckError(
            f"{name}: not finite at (x, y) = ({X[bad]:.3g}, {Y[bad]:.3g}) inside the disc of radius "
            f"{radius} the rod can reach")
    scale = max(float(np.max(norm)), 1e-300)
    for label, arr in (("divergence", div), ("curl", curl)):
        k = int(np.argmax(np.abs(arr)))
        if abs(arr[k]) > rtol * scale:
            raise FieldCheckError(
                f"{name}: {label} is {arr[k]:.3g} at (x, y) = ({X[k]:.3g}, {Y[k]:.3g}) (|grad h| up to "
                f"{scale:.3g}); an applied field must be divergence- and curl-free where the rod can "
                f"reach (|r| <= {radius} rod lengths)")
