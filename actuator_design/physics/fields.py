"""Applied fields ĥ(x, y), kept apart from their coupling to the rod (THEORY §3).

Each field evaluates its dimensionless direction-and-shape ĥ at rod positions as CasADi expressions,
so every gradient the solver needs (the field-gradient force on the rod included) is exact. The field
strength is not here: it is the scene's group ``h`` (THEORY §5).
"""
from __future__ import annotations

import math
from typing import Dict, Tuple

import casadi as ca
import numpy as np

from ..expressions import Expression
from ..scene import DipoleField, ExpressionField, UniformField

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


class ExpressionFieldModel(FieldModel):
    """A user field (hx(x, y), hy(x, y)) from safe expressions (``actuator_design.expressions``)."""

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


def field_model(field) -> FieldModel:
    """The :class:`FieldModel` for a scene field dataclass."""
    if isinstance(field, UniformField):
        return UniformFieldModel()
    if isinstance(field, DipoleField):
        return DipoleFieldModel()
    if isinstance(field, ExpressionField):
        return ExpressionFieldModel(field)
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
    values = values or {}
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
