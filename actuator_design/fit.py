"""Calibration: fit scene parameters to measured equilibria, with confidence intervals.

A configuration gives the scene (what is known) and a ``study:`` section of ``type: fit`` naming
the parameters to fit; a CSV file (:mod:`actuator_design.fitdata`) holds the measurements::

    study:
      type: fit
      parameters:                       # initial value and bounds, with units
        chi_bar: {initial: 0.3, bounds: [0.01, 5]}
        clamp_angle: {initial: 0 deg, bounds: [-5 deg, 5 deg]}
      uncertainty: {tip_angle: 0.5 deg} # optional: σ of each measured column (weights)
      confidence: 0.95

Fittable parameters (:data:`PARAMETERS`): ``chi_bar`` (χ̄), ``youngs_modulus`` (E) or
``bending_stiffness`` (B0) — physical scenes; ``h`` (the group at ``reference_field``, or the scene's
h when the data have no field column) — dimensionless scenes; ``clamp_angle`` (θ0), ``field_scale``
(measured field × scale), ``field_offset`` (added to the measured field) and ``field_angle_offset``
(added to the field angle) — both.

Method (nested least squares with exact sensitivities)
-----------------------------------------------------
For each data point i the inputs (field H_i, field angle, load) and the parameters give the
dimensionless groups of THEORY §5 (h_i² = μ0 χ̄ H_i² A ℓ²/(2B), p_i = P_i ℓ²/B, …); its equilibrium
z_i is found by damped Newton on the discrete stationarity system of the solver built once for
the scene structure, warm-started from the same point's previous solution (or, the first time,
along the data sorted by their inputs). Only stable equilibria are accepted (THEORY §7): an
unstable one is left along its unstable mode in the direction of the measurement, and the first
time every point tries the straight rod and the mirrored shape too and keeps the stable
equilibrium closest to its measurement — data beyond a pitchfork or fold are fitted on the branch
they were measured on (e.g. the sign of the buckled angle in a transverse field, THEORY §6, §8).

The tip y = T(z, q) depends on the NLP parameters q (h, φ, forces, θ0) directly and through
z(q), defined by ∇_r Ê(z, q) = 0. The implicit function theorem gives
dz/dq = −H_r⁻¹ ∂(∇_r Ê)/∂q with H_r the reduced Hessian, so dy/dq = ∂T/∂z dz/dq + ∂T/∂q, and
q(θ) is an explicit (CasADi) map of the fitted parameters θ. These exact Jacobians drive
``scipy.optimize.least_squares`` (trust region, bounds; positive parameters in log scale).

Uncertainty: with weighted residuals r (m of them) and Jacobian J at the optimum,
cov = s² (JᵀJ)⁻¹, s² = |r|²/(m − k). Intervals are t-intervals with m − k degrees of freedom
(in log scale for positive parameters, so they stay positive). Identifiability: when the
column-normalised J has a singular value below ``identifiability_tol`` times the largest, a
combination of parameters is not determined by the data (e.g. a field-only data set determines
χ̄ and E only through h² ∝ χ̄/E): the fit says so, holds one parameter at its initial value, fits
the others and reports the identifiable combination (e.g. ``chi_bar * youngs_modulus^-1``) with
its interval.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Dict, List, Literal, Optional, Tuple, Union

import casadi as ca
import numpy as np
import scipy.linalg
import scipy.optimize
import scipy.stats
from pydantic import Field, StrictFloat, StrictInt, StrictStr, model_validator

from .config import ConfigError, load_config
from .fitdata import COLUMNS, DataError, MeasuredData, read_data
from .options import SolverOptions
from .scene import Scene, UniformField
from .solver import EquilibriumSolver, get_solver
from .study.spec import StrictModel, spec_error, validate_spec
from .units import MU0, DIMENSIONS, QuantityError, parse_quantity

__all__ = ["PARAMETERS", "FitSpec", "FitProblem", "FitResult", "prepare_fit", "fit", "fit_config",
           "write_fit", "points_csv_text"]


@dataclass(frozen=True)
class _Param:
    dimension: str
    log: bool  # positive parameter, fitted in log scale
    scenes: Tuple[str, ...]
    description: str


#: Fittable parameters: dimension (for units), scale, scene types, meaning.
PARAMETERS: Dict[str, _Param] = {
    "chi_bar": _Param("dimensionless", True, ("physical",), "orientational susceptibility χ̄"),
    "youngs_modulus": _Param("pressure", True, ("physical",), "Young's modulus E (B0 = E I)"),
    "bending_stiffness": _Param("bending_stiffness", True, ("physical",), "bending stiffness B0"),
    "h": _Param("dimensionless", True, ("dimensionless",), "field group h (THEORY §5)"),
    "clamp_angle": _Param("angle", False, ("physical", "dimensionless"), "clamp angle θ0"),
    "field_scale": _Param("dimensionless", True, ("physical", "dimensionless"),
                          "factor on the measured field"),
    "field_offset": _Param("magnetic_field", False, ("physical", "dimensionless"),
                           "offset added to the measured field"),
    "field_angle_offset": _Param("angle", False, ("physical", "dimensionless"),
                                 "offset added to the field angle"),
}

#: Output columns → component of the tip (θ(1), x(1), y(1)) and whether it is a length.
_OUTPUT_COMPONENT = {"tip_angle": (0, False), "tip_x": (1, True), "tip_y": (2, True),
                     "tip_deflection": (2, True)}
#: NLP parameter slots a fit may change (when the scene structure has them).
_SLOTS = ("h", "phi", "fx", "fy", "qx", "qy", "m_tip", "theta0")

Value = Union[StrictInt, StrictFloat, StrictStr]


# -- specification ----------------------------------------------------------------------------------
class ParameterSpec(StrictModel):
    """One fitted parameter: initial value (default: the scene's value) and bounds, with units."""

    initial: Optional[Value] = None
    bounds: Optional[List[Value]] = None


class FitSpec(StrictModel):
    """The ``study:`` section of a fit (see the module docstring)."""

    type: Literal["fit"]
    parameters: Dict[str, ParameterSpec]
    uncertainty: Dict[str, Value] = {}
    confidence: StrictFloat = Field(default=0.95, gt=0.5, lt=1.0)
    reference_field: Optional[Value] = None
    ignore_columns: List[StrictStr] = []
    curve_points: StrictInt = Field(default=101, ge=2, le=10_000)
    identifiability_tol: StrictFloat = Field(default=1e-6, gt=0.0, lt=1.0)
    max_nfev: StrictInt = Field(default=200, ge=1)

    @model_validator(mode="after")
    def _check(self):
        if not self.parameters:
            raise spec_error("name at least one parameter to fit (allowed: "
                             f"{', '.join(PARAMETERS)})", "parameters")
        if "youngs_modulus" in self.parameters and "bending_stiffness" in self.parameters:
            raise spec_error("fit either youngs_modulus or bending_stiffness, not both",
                             "parameters.bending_stiffness")
        for name, p in self.parameters.items():
            where = f"parameters.{name}"
            if name not in PARAMETERS:
                raise spec_error(f"unknown parameter (allowed: {', '.join(PARAMETERS)})", where)
            info = PARAMETERS[name]
            init = None if p.initial is None else _quantity(p.initial, info.dimension,
                                                            f"{where}.initial")
            if p.bounds is not None:
                if len(p.bounds) != 2:
                    raise spec_error(f"expected [lower, upper], got {p.bounds!r}", f"{where}.bounds")
                lo, hi = (_quantity(b, info.dimension, f"{where}.bounds") for b in p.bounds)
                if not lo < hi:
                    raise spec_error(f"lower bound must be < upper bound, got {p.bounds!r}",
                                     f"{where}.bounds")
                if info.log and lo <= 0:
                    raise spec_error(f"{name} is positive: its lower bound must be > 0, got "
                                     f"{p.bounds[0]!r}", f"{where}.bounds")
                if init is not None and not lo <= init <= hi:
                    raise spec_error(f"initial value {p.initial!r} lies outside the bounds "
                                     f"{p.bounds!r}", f"{where}.initial")
            if info.log and init is not None and init <= 0:
                raise spec_error(f"{name} is positive: must be > 0, got {p.initial!r}",
                                 f"{where}.initial")
        for name, v in self.uncertainty.items():
            if name not in _OUTPUT_COMPONENT:
                raise spec_error(f"not a measured output (allowed: {', '.join(_OUTPUT_COMPONENT)})",
                                 f"uncertainty.{name}")
        return self

    def bounds_of(self, name: str) -> Tuple[float, float]:
        p, info = self.parameters[name], PARAMETERS[name]
        if p.bounds is None:
            return (0.0 if info.log else -math.inf), math.inf
        return tuple(parse_quantity(b, info.dimension) for b in p.bounds)


def _quantity(value, dimension, where) -> float:
    try:
        return parse_quantity(value, dimension, where.rsplit(".", 1)[-1])
    except QuantityError as err:
        raise spec_error(err.detail, where) from None


# -- the problem: data + model map + solver ---------------------------------------------------------
@dataclass(frozen=True)
class _Stable:
    """Verdict of a positive definite reduced Hessian (no eigen-analysis needed)."""

    stable: bool = True
    marginal: bool = False
    morse_index: int = 0
    eigenvector: Optional[np.ndarray] = None


_STABLE = _Stable()


@dataclass
class _Point:
    z: Optional[np.ndarray] = None  # tracked equilibrium (warm start)
    converged: bool = False
    stable: bool = False
    morse_index: int = -1


class FitProblem:
    """Measured data, the map θ → NLP parameters, and the equilibrium solver of the structure.

    Parameters
    ----------
    config : Config
        Validated configuration (``actuator_design.config.load_config``); its ``study`` section is
        the fit specification.
    data : MeasuredData

    Raises
    ------
    ConfigError
        The specification does not fit the scene (field ``study.<…>`` or ``scene.<…>``).
    DataError
        The data do not fit the specification (a missing column, too few points).
    """

    def __init__(self, config, data: MeasuredData, spec: Optional[FitSpec] = None):
        self.config = config
        self.spec = spec or validate_spec(FitSpec, config.study or {})
        self.data = data
        self.kind = config.scene.type
        self.options: SolverOptions = config.solver_options()
        self.names: List[str] = list(self.spec.parameters)
        self._check_data()
        self.scene = self._structure_scene(config.to_scene())
        self._constants()
        self.solver: EquilibriumSolver = get_solver(self.scene, self.options)
        self._build_functions()
        self._prepare_points()

    # -- checks ---------------------------------------------------------------------------------
    def _check_data(self) -> None:
        cols, spec, src = self.data.columns, self.spec, self.data.source
        for name in self.names:
            if self.kind not in PARAMETERS[name].scenes:
                raise ConfigError(f"study.parameters.{name}",
                                  f"cannot be fitted in a {self.kind} scene (fit "
                                  f"{'chi_bar / youngs_modulus' if self.kind == 'physical' else 'h'} "
                                  "instead)")
        if self.kind == "physical":
            rod = self.config.scene.rod
            if "youngs_modulus" in self.names and rod.youngs_modulus is None:
                raise ConfigError("study.parameters.youngs_modulus",
                                  "the scene gives rod.bending_stiffness: fit bending_stiffness")
            if "bending_stiffness" in self.names and rod.bending_stiffness is None:
                raise ConfigError("study.parameters.bending_stiffness",
                                  "the scene gives rod.youngs_modulus: fit youngs_modulus")
        if ("field_scale" in self.names or "field_offset" in self.names) and "field" not in cols:
            name = "field_scale" if "field_scale" in self.names else "field_offset"
            raise DataError(f"{src}: column 'field' missing: study.parameters.{name} needs measured "
                            "fields (e.g. 'field [kA/m]')", column="field")
        if self.kind == "dimensionless" and "field" in cols and spec.reference_field is None:
            raise ConfigError("study.reference_field", "required with a 'field' column in a "
                                                       "dimensionless scene (h is the group at this "
                                                       "field), e.g. '10 kA/m'")
        for name in spec.uncertainty:
            if name not in cols:
                raise ConfigError(f"study.uncertainty.{name}",
                                  f"no column '{name}' in {src} (its outputs: "
                                  f"{', '.join(self.data.outputs)})")
        n_meas = self.data.n * len(self.data.outputs)
        if n_meas <= len(self.names):
            raise DataError(f"{src}: {self.data.n} data point(s) with {len(self.data.outputs)} "
                            f"measured output(s) cannot determine {len(self.names)} parameter(s) "
                            "with uncertainties: give more measurements than parameters")

    def _structure_scene(self, scene: Scene) -> Scene:
        """The scene with the terms the data need (a tip force for load columns)."""
        cols = self.data.columns
        needs_field = ("field" in cols or "field_angle" in cols or
                       {"chi_bar", "h", "field_scale", "field_offset",
                        "field_angle_offset"} & set(self.names))
        if scene.field is not None and not isinstance(scene.field, UniformField):
            raise ConfigError("scene.field", f"fitting supports uniform fields (or none), got a "
                                             f"{scene.field.kind} field")
        if needs_field and scene.field is None:
            raise ConfigError("scene.field", "the fit involves the field (a field column or a field "
                                             "parameter): give the scene a uniform field")
        if ({"load", "load_x", "load_y"} & set(cols)) and scene.tip_force is None:
            scene = dataclasses.replace(scene, tip_force=(0.0, 0.0))
        return scene

    def _constants(self) -> None:
        """Known values the map θ → NLP parameters needs (SI; B0 = 1 for dimensionless)."""
        sc, c = self.scene, {}
        if self.kind == "physical":
            rod = self.config.scene.rod
            c["L"], c["A"], c["B0"] = rod.length, rod.cross_section_area, rod.clamp_stiffness
            c["E0"] = rod.youngs_modulus
            mag = self.config.scene.magnetics
            c["chi0"] = mag.susceptibilities()[0] if mag is not None else 0.0
            c["H0"] = sc.scales.field
        else:
            c["L"], c["B0"], c["h0"] = 1.0, 1.0, sc.h
            c["Href"] = (parse_quantity(self.spec.reference_field, "magnetic_field",
                                        "reference_field")
                         if self.spec.reference_field is not None else None)
            if c["Href"] is not None and c["Href"] <= 0:
                raise ConfigError("study.reference_field", f"must be > 0, got "
                                                           f"{self.spec.reference_field!r}")
        c["phi0"], c["theta00"] = sc.phi, sc.theta0
        c["f0"] = sc.tip_force or (0.0, 0.0)
        c["q0"] = sc.distributed_load or (0.0, 0.0)
        c["m0"] = sc.tip_moment or 0.0
        self.const = c
        # initial values (natural units): given, else the scene's value
        init = {}
        for name in self.names:
            given = self.spec.parameters[name].initial
            if given is not None:
                init[name] = parse_quantity(given, PARAMETERS[name].dimension)
            else:
                init[name] = self._scene_value(name)
            lo, hi = self.spec.bounds_of(name)
            if not lo <= init[name] <= hi:
                raise ConfigError(f"study.parameters.{name}.initial",
                                  f"the scene's value {init[name]:g} lies outside the bounds; give "
                                  "an initial value")
            if PARAMETERS[name].log and not init[name] > 0:
                raise ConfigError(f"study.parameters.{name}.initial",
                                  f"must be > 0, the scene gives {init[name]:g}")
        self.initial = init

    def _scene_value(self, name: str) -> float:
        c = self.const
        return {"chi_bar": lambda: c["chi0"], "youngs_modulus": lambda: c["E0"],
                "bending_stiffness": lambda: c["B0"], "h": lambda: c["h0"],
                "clamp_angle": lambda: c["theta00"], "field_scale": lambda: 1.0,
                "field_offset": lambda: 0.0, "field_angle_offset": lambda: 0.0}[name]()

    # -- symbolic map θ, inputs → NLP slots, and the sensitivity functions ----------------------
    def _build_functions(self) -> None:
        c, cols, layout = self.const, self.data.columns, self.solver.layout
        k = len(self.names)
        th = ca.SX.sym("theta", k)
        u = ca.SX.sym("u", 4)  # H, field angle, Fx, Fy of one data point (SI or dimensionless)
        v = {n: th[i] for i, n in enumerate(self.names)}
        get = lambda n, default: v.get(n, default)  # noqa: E731
        if self.kind == "physical":
            H = u[0] if "field" in cols else c["H0"]
        else:
            H = u[0] if "field" in cols else None
        if H is not None:
            H = get("field_scale", 1.0) * H + get("field_offset", 0.0)
        if self.kind == "physical":
            if "youngs_modulus" in v:
                B = v["youngs_modulus"] / c["E0"] * c["B0"]
            else:
                B = get("bending_stiffness", c["B0"])
            chi = get("chi_bar", c["chi0"])
            h = ca.sqrt(MU0 * chi * c["A"] * c["L"] ** 2 / (2.0 * B)) * H
        else:
            B = c["B0"]
            hh = get("h", c["h0"])
            h = hh * H / c["Href"] if H is not None else hh
        ratio = c["B0"] / B  # dimensionless loads scale with 1/B
        scale_F = c["L"] ** 2 / B if self.kind == "physical" else 1.0
        fx = u[2] * scale_F if "load_x" in cols else c["f0"][0] * ratio
        fy = u[3] * scale_F if ("load" in cols or "load_y" in cols) else c["f0"][1] * ratio
        slot_expr = {
            "h": h, "phi": (u[1] if "field_angle" in cols else c["phi0"]) + get("field_angle_offset", 0.0),
            "fx": fx, "fy": fy, "qx": c["q0"][0] * ratio, "qy": c["q0"][1] * ratio,
            "m_tip": c["m0"] * ratio, "theta0": get("clamp_angle", c["theta00"]),
        }
        self.slots = [s for s in _SLOTS if s in layout.slices]
        self.slot_index = np.array([layout.slices[s].start for s in self.slots])
        q = ca.vertcat(*[ca.SX(slot_expr[s]) for s in self.slots])
        self.f_map = ca.Function("fit_map", [th, u], [q, ca.jacobian(q, th)])

        de = self.solver.discrete
        z, P = de.z, de.params
        zr = ca.SX.sym("theta_free", z.numel() - 1)
        zfull = ca.vertcat(P[layout.slices["theta0"]], zr)
        Er = ca.substitute(de.energy, z, zfull)
        gr = ca.gradient(Er, zr)
        Hr = ca.hessian(Er, zr)[0]
        tip = ca.substitute(ca.vertcat(*de.tip), z, zfull)
        self.f_hess = ca.Function("fit_hess", [zr, P], [Hr])
        self.f_sens = ca.Function("fit_sens", [zr, P],
                                  [Hr, ca.jacobian(gr, P), tip, ca.jacobian(tip, zr),
                                   ca.jacobian(tip, P)])
        self.base_params = self.solver.parameter_vector(self.scene)

    def _prepare_points(self) -> None:
        d = self.data
        n = d.n
        U = np.zeros((n, 4))
        for j, name in enumerate(("field", "field_angle", "load_x", None)):
            if name in d.columns:
                U[:, j] = d.columns[name]
        for name in ("load", "load_y"):
            if name in d.columns:
                U[:, 3] = d.columns[name]
        self.U = U
        # warm starts help along sorted data: field angle, then field, then loads
        self.order = np.lexsort((U[:, 2], U[:, 3], U[:, 0], U[:, 1]))
        self.outputs = d.outputs
        self.Y = np.column_stack([d.columns[o] for o in self.outputs])  # (n, n_out), SI
        self.comp = [_OUTPUT_COMPONENT[o][0] for o in self.outputs]
        self.out_scale = np.array([self.const["L"] if (_OUTPUT_COMPONENT[o][1] and
                                                       self.kind == "physical") else 1.0
                                   for o in self.outputs])
        sigma = []
        for o in self.outputs:
            if o in self.spec.uncertainty:
                dim = COLUMNS[o][2 if self.kind == "dimensionless" else 1]
                try:
                    s = parse_quantity(self.spec.uncertainty[o], dim, o)
                except QuantityError as err:
                    raise ConfigError(f"study.uncertainty.{o}", err.detail) from None
                if not s > 0:
                    raise ConfigError(f"study.uncertainty.{o}", f"must be > 0, got "
                                                                f"{self.spec.uncertainty[o]!r}")
            else:
                col = d.columns[o]
                s = float(np.sqrt(np.mean(col**2))) or 1.0  # provisional scale; re-estimated
            sigma.append(s)
        self.sigma = np.array(sigma)
        self.sigma_given = np.array([o in self.spec.uncertainty for o in self.outputs])
        self.points = [_Point() for _ in range(n)]

    # -- evaluation -----------------------------------------------------------------------------
    def nlp_params(self, theta: np.ndarray, u: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """NLP parameter vector for one point, and d(slots)/dθ, shape (n_slots, k)."""
        q, dq = self.f_map(theta, u)
        P = self.base_params.copy()
        P[self.slot_index] = np.asarray(q, float).ravel()
        return P, np.asarray(dq, float).reshape(len(self.slots), -1)

    def _model_outputs(self, z: np.ndarray, P: np.ndarray) -> np.ndarray:
        tip = np.array([float(t) for t in self.solver.f_tip(z, P)])
        return tip[self.comp] * self.out_scale

    def _misfit(self, i: int):
        return self._target_misfit(self.Y[i])

    def _target_misfit(self, y: np.ndarray):
        """(z, P) → weighted squared distance of the model outputs from ``y``."""
        w = 1.0 / self.sigma
        return lambda z, P: float(np.sum(((self._model_outputs(z, P) - y) * w) ** 2))

    def _converge(self, z0: np.ndarray, P: np.ndarray, minimise: bool = False):
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

    def _verdict(self, z: np.ndarray, P: np.ndarray):
        """Stability (THEORY §7): a Cholesky factorisation of the reduced Hessian proves it
        positive definite cheaply; otherwise the solver's eigen-analysis (Morse index, mode)."""
        try:
            np.linalg.cholesky(np.asarray(self.f_hess(z[1:], P), float))
            return _STABLE
        except np.linalg.LinAlgError:
            return self.solver.stability(z, P)

    def stable_equilibrium(self, z0: np.ndarray, P: np.ndarray, misfit):
        """Converge from ``z0``; leave an unstable equilibrium along its unstable mode in the
        direction that brings the model closer to the measurement (``misfit(z, P)``).

        Returns
        -------
        z : ndarray, shape (n_nodes,)
        converged : bool
        verdict : StabilityVerdict or None
        """
        raw = self._converge(z0, P)
        if not raw.converged:
            return raw.z, False, None
        verdict = self._verdict(raw.z, P)
        z = raw.z
        for _ in range(3):
            if verdict.stable or verdict.marginal:
                break
            v = verdict.eigenvector
            starts = sorted((z + a * v for a in (0.2, -0.2)), key=lambda zz: misfit(zz, P))
            for start in starts:
                trial = self._converge(start, P, minimise=True)
                if trial.converged:
                    z, verdict = trial.z, self._verdict(trial.z, P)
                    break
            else:
                break
        return z, True, verdict

    def _solve_point(self, i: int, theta: np.ndarray, select: bool, z_prev: Optional[np.ndarray]):
        P, dq = self.nlp_params(theta, self.U[i])
        misfit = self._misfit(i)
        straight = np.full(self.solver.transcription.nodes.size, P[self.solver.layout.slices["theta0"]][0])
        pt = self.points[i]
        starts = []
        if pt.z is not None and not select:
            starts.append(pt.z)
        else:
            if z_prev is not None:
                starts += [z_prev, 2.0 * straight - z_prev]
            if pt.z is not None:
                starts.append(pt.z)
            starts.append(straight)
        best = None
        for attempt in range(2):
            for z0 in starts:
                z, ok, verdict = self.stable_equilibrium(z0, P, misfit)
                if not ok:
                    continue
                key = (not (verdict.stable or verdict.marginal), misfit(z, P))
                if best is None or key < best[0]:
                    best = (key, z, verdict)
            if best is not None and not best[0][0]:
                break
            # the tracked start failed or stayed unstable: fall back to the wider set of starts
            starts = [s for s in ([z_prev, 2.0 * straight - z_prev] if z_prev is not None else [])]
            starts.append(straight)
        if best is None:
            pt.converged, pt.stable, pt.morse_index = False, False, -1
            z = pt.z if pt.z is not None else straight
        else:
            _, z, verdict = best
            pt.z, pt.converged = z, True
            pt.stable, pt.morse_index = bool(verdict.stable or verdict.marginal), verdict.morse_index
        return z, P, dq

    def _sensitivity(self, z: np.ndarray, P: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """d(outputs)/dθ (natural units), shape (n_out, k), by the implicit function theorem."""
        Hr, Gp, tip, Tz, Tp = (np.asarray(a, float) for a in self.f_sens(z[1:], P))
        Gq = Gp[:, self.slot_index]
        try:
            dz = -scipy.linalg.solve(Hr, Gq, assume_a="sym")
        except (np.linalg.LinAlgError, ValueError):
            dz = -np.linalg.lstsq(Hr, Gq, rcond=None)[0]
        dtip_dq = Tz @ dz + Tp[:, self.slot_index]
        return (dtip_dq[self.comp] * self.out_scale[:, None]) @ dq

    def evaluate(self, theta: np.ndarray, select: bool = False, jacobian: bool = True):
        """Model outputs (n, n_out) in SI, and their Jacobian (n, n_out, k) in natural units.

        ``select``: re-choose every point's branch (closest stable equilibrium to the data).
        """
        n, k = self.data.n, len(self.names)
        model = np.zeros((n, len(self.outputs)))
        jac = np.zeros((n, len(self.outputs), k)) if jacobian else None
        z_prev = None
        for i in self.order:
            z, P, dq = self._solve_point(int(i), theta, select, z_prev)
            model[i] = self._model_outputs(z, P)
            if jacobian:
                jac[i] = self._sensitivity(z, P, dq)
            z_prev = z
        return model, jac

    # -- model curves for figures -----------------------------------------------------------------
    def curves(self, theta: np.ndarray, n_points: int) -> Dict[str, Any]:
        """Model outputs along the primary input, one curve per group of the other inputs.

        The primary input is the input column with the most distinct values; each curve starts
        from the fitted equilibrium of its group's first data point and continues by warm starts,
        keeping the stable branch nearest to the nearest measurement (as the fit does).

        Returns
        -------
        dict
            ``x`` (input name or None), ``groups``: list of {"label", "inputs": {name: value SI},
            "x": ndarray (m,), "y": {output: ndarray (m,) SI}, "stable": ndarray (m,) bool}.
        """
        d = self.data
        names = [c for c in ("field", "load", "load_y", "load_x", "field_angle") if c in d.columns]
        if not names:
            return {"x": None, "groups": []}
        primary = max(names, key=lambda c: len(np.unique(d.columns[c])))
        col_of = {"field": 0, "field_angle": 1, "load_x": 2, "load": 3, "load_y": 3}
        jp = col_of[primary]
        others = [c for c in names if c != primary]
        keys = [tuple(d.columns[c][i] for c in others) for i in range(d.n)]
        groups = []
        for key in dict.fromkeys(keys):
            idx = np.array([i for i in range(d.n) if keys[i] == key])
            idx = idx[np.argsort(self.U[idx, jp])]
            x0, x1 = self.U[idx[0], jp], self.U[idx[-1], jp]
            xs = np.linspace(x0, x1, n_points)
            u = self.U[idx[0]].copy()
            z = self.points[idx[0]].z
            ys, stable = np.zeros((n_points, len(self.outputs))), np.zeros(n_points, bool)
            xd = self.U[idx, jp]
            for m, x in enumerate(xs):
                u[jp] = x
                P, _ = self.nlp_params(theta, u)
                # the measurement interpolated at x picks the branch, as for the data points
                target = np.array([np.interp(x, xd, self.Y[idx, j]) for j in range(self.Y.shape[1])])
                misfit = self._target_misfit(target)
                straight = np.full(self.solver.transcription.nodes.size,
                                   P[self.solver.layout.slices["theta0"]][0])
                best = None
                starts = [straight] if z is None else [z, 2.0 * straight - z]
                for z0 in starts:
                    z_new, ok, verdict = self.stable_equilibrium(z0, P, misfit)
                    if not ok:
                        continue
                    rank = (not (verdict.stable or verdict.marginal), misfit(z_new, P))
                    if best is None or rank < best[0]:
                        best = (rank, z_new)
                if best is None:
                    ys[m] = np.nan
                    continue
                z = best[1]
                ys[m] = self._model_outputs(z, P)
                stable[m] = not best[0][0]
            label = ", ".join(f"{c} = {d.as_given(c, [v])[0]:.4g} {d.units[c]}".strip()
                              for c, v in zip(others, key))
            groups.append({"label": label, "inputs": dict(zip(others, key)), "x": xs,
                           "y": {o: ys[:, j] for j, o in enumerate(self.outputs)}, "stable": stable})
        return {"x": primary, "groups": groups}


# -- the fit ----------------------------------------------------------------------------------------
@dataclass
class FitResult:
    """Fitted parameters with intervals, residuals, identifiability, and the fitted model.

    Attributes
    ----------
    success : bool
        The optimiser converged and every data point has a converged, stable equilibrium.
    status, message : str
    parameters : dict
        name → {"value", "unit", "std", "ci": [low, high], "initial", "bounds", "fitted",
        "scale"} in SI units (``fitted`` False for a parameter held because it was not
        identifiable).
    confidence : float
    identifiable : bool
    warnings : list of str
    combinations : list of dict
        Identifiable combinations reported when parameters were held.
    covariance, correlation : ndarray, shape (k, k)
        Of the fitted parameters (natural units), in ``fitted_names`` order.
    singular_values : ndarray
        Of the column-normalised weighted Jacobian, relative to the largest.
    residuals : ndarray, shape (n, n_out)
        Model − data, SI units.
    model : ndarray, shape (n, n_out)
    s2 : float
        Residual variance of the weighted residuals.
    """

    success: bool
    status: str
    message: str
    parameters: Dict[str, dict]
    fitted_names: List[str]
    confidence: float
    identifiable: bool
    warnings: List[str]
    combinations: List[dict]
    derived: Dict[str, dict]
    covariance: np.ndarray
    correlation: np.ndarray
    singular_values: np.ndarray
    model: np.ndarray
    residuals: np.ndarray
    sigma: np.ndarray
    s2: float
    dof: int
    optimizer: Dict[str, Any]
    points: List[dict]
    curves: Dict[str, Any]
    data: MeasuredData
    outputs: List[str]
    name: str = "fit"
    solver: Dict[str, Any] = field(default_factory=dict)

    @property
    def rms(self) -> Dict[str, float]:
        """RMS residual of each output column, in the unit of the data file."""
        return {o: float(np.sqrt(np.mean(self.data.as_given(o, self.residuals[:, j]) ** 2)))
                for j, o in enumerate(self.outputs)}

    def to_dict(self) -> Dict[str, Any]:
        """The JSON contract of ``actuator-design fit --json``."""
        return {
            "success": bool(self.success), "status": self.status, "message": self.message,
            "name": self.name,
            "parameters": self.parameters, "confidence": self.confidence,
            "identifiable": bool(self.identifiable), "warnings": list(self.warnings),
            "combinations": self.combinations, "derived": self.derived,
            "fitted_parameters": list(self.fitted_names),
            "covariance": self.covariance.tolist(), "correlation": self.correlation.tolist(),
            "singular_values": self.singular_values.tolist(),
            "n_points": int(self.data.n), "n_residuals": int(self.residuals.size),
            "dof": int(self.dof), "s2": float(self.s2),
            "rms": self.rms, "units": dict(self.data.units),
            "sigma": {o: float(self.sigma[j]) for j, o in enumerate(self.outputs)},
            "data": {"source": self.data.source, "columns": dict(self.data.units),
                     "comments": list(self.data.comments)},
            "points": self.points, "optimizer": self.optimizer, "solver": self.solver,
        }

    def summary(self) -> str:
        """A readable multi-line report."""
        pct = f"{100 * self.confidence:g}%"
        lines = [f"fit: {self.name}",
                 f"  data        : {self.data.source}, {self.data.n} points, outputs "
                 f"{', '.join(self.outputs)}",
                 f"  status      : {self.status} ({'success' if self.success else 'FAILED'}) — "
                 f"{self.message}",
                 f"  parameters  : value [{pct} confidence interval]"]
        for name, p in self.parameters.items():
            unit = f" {p['unit']}" if p["unit"] else ""
            if not p["fitted"]:
                lines.append(f"    {name:<18s} = {p['value']:.6g}{unit}  (held: not identifiable)")
                continue
            extra = ""
            if PARAMETERS[name].dimension == "angle":
                extra = f"  ({math.degrees(p['value']):.4g} deg)"
            lines.append(f"    {name:<18s} = {p['value']:.6g}{unit} ± {p['std']:.2g}  "
                         f"[{p['ci'][0]:.6g}, {p['ci'][1]:.6g}]{extra}")
        for c in self.combinations:
            lines.append(f"    {c['name']:<18s} = {c['value']:.6g} {c['unit']}  "
                         f"[{c['ci'][0]:.6g}, {c['ci'][1]:.6g}]  (identifiable combination)")
        for name, dv in self.derived.items():
            lines.append(f"    {name:<18s} = {dv['value']:.6g} {dv['unit']}  "
                         f"[{dv['ci'][0]:.6g}, {dv['ci'][1]:.6g}]  (derived: {dv['description']})")
        rms = ", ".join(f"{o} {v:.4g} {self.data.units[o]}".rstrip() for o, v in self.rms.items())
        lines.append(f"  residuals   : rms {rms}; s² = {self.s2:.4g} (weighted), dof {self.dof}")
        n_unstable = sum(1 for p in self.points if not p["stable"])
        n_failed = sum(1 for p in self.points if not p["converged"])
        lines.append(f"  equilibria  : {self.data.n - n_failed} converged, "
                     f"{self.data.n - n_unstable} stable")
        for w in self.warnings:
            lines.append(f"  warning     : {w}")
        return "\n".join(lines)


def _exp(x: float) -> float:
    """exp without OverflowError (an unbounded interval is +inf)."""
    with np.errstate(over="ignore"):
        return float(np.exp(x))


def _unit(name: str) -> str:
    return DIMENSIONS[PARAMETERS[name].dimension].unit


def prepare_fit(config_source, data_source) -> FitProblem:
    """Load and check a fit: configuration (path or dict) and data (path or :class:`MeasuredData`).

    Everything that can be wrong with the input is found here, before any fitting.

    Raises
    ------
    ConfigError, DataError
        Invalid configuration, specification or data (one line each; both are ``ValueError``).
    """
    config = load_config(config_source)
    study = config.study or {}
    if study.get("type") != "fit":
        raise ConfigError("study.type", f"a fit needs 'study: {{type: fit, parameters: ...}}', got "
                                        f"{study.get('type')!r}")
    spec = validate_spec(FitSpec, study)
    if isinstance(data_source, MeasuredData):
        data = data_source
    else:
        data = read_data(data_source, dimensionless=config.scene.type == "dimensionless",
                         ignore_columns=spec.ignore_columns)
    return FitProblem(config, data, spec)


def fit_config(config_source, data_source) -> FitResult:
    """:func:`prepare_fit` then :func:`fit`."""
    return fit(prepare_fit(config_source, data_source))


def fit(problem: FitProblem) -> FitResult:
    """Least-squares fit of ``problem`` (see the module docstring for the method)."""
    spec = problem.spec
    names = problem.names
    k_all = len(names)
    theta = np.array([problem.initial[n] for n in names], float)
    free = list(range(k_all))
    held: Dict[int, str] = {}
    warnings: List[str] = []
    combinations: List[dict] = []
    is_log = np.array([PARAMETERS[n].log for n in names])
    bounds = [spec.bounds_of(n) for n in names]
    reweighted = bool(np.all(problem.sigma_given)) or len(problem.outputs) == 1
    reselected = 0
    cache: Dict[str, Any] = {}
    n_res = problem.data.n * len(problem.outputs)

    def to_x(th):
        return np.where(is_log, np.log(np.maximum(th, 1e-300)), th)[free]

    def to_theta(x):
        th = theta.copy()
        th[free] = np.where(is_log[free], np.exp(x), x)
        return th

    def compute(x, select=False):
        th = to_theta(x)
        model, jac = problem.evaluate(th, select=select)
        r = ((model - problem.Y) / problem.sigma).T.ravel()  # output-major
        Jn = (jac / problem.sigma[None, :, None]).transpose(1, 0, 2).reshape(n_res, -1)[:, free]
        Jx = Jn * np.where(is_log[free], th[free], 1.0)[None, :]  # d/dlog p = p d/dp
        cache.update(x=np.array(x), r=r, J=Jx, model=model)
        return r, Jx

    def fun(x):
        if "x" in cache and np.array_equal(cache["x"], x):
            return cache["r"]
        return compute(x)[0]

    def jac(x):
        if "x" in cache and np.array_equal(cache["x"], x):
            return cache["J"]
        return compute(x)[1]

    def hold(null) -> None:
        """Hold the parameter the null direction leans on most; record the message."""
        nonlocal free
        vec, rel, colnorm = null
        j = free[_choose_held(vec, colnorm)]
        warnings.append(_identifiability_message(names, free, vec, j, rel, is_log, problem))
        combinations.extend(_combinations(names, free, vec, j, is_log, theta))
        held[j] = names[j]
        free = [i for i in free if i != j]
        theta[j] = problem.initial[names[j]]
        compute(to_x(theta))

    # first evaluation: choose every point's branch at the initial guess
    compute(to_x(theta), select=True)
    # a structural degeneracy (proportional sensitivities, e.g. χ̄ and E through h² only) shows
    # already here; a zero sensitivity may be accidental (e.g. all points below a threshold)
    null = _null_direction(cache["J"], spec.identifiability_tol)
    while null is not None and len(free) > 1 and null[1] < 1e-10 and np.all(null[2] > 0):
        hold(null)
        null = _null_direction(cache["J"], spec.identifiability_tol)
    opt = None
    nfev = njev = 0
    for _round in range(3 * k_all + 6):
        lo = np.array([np.log(b[0]) if is_log[i] and b[0] > 0 else (-np.inf if is_log[i] else b[0])
                       for i, b in enumerate(bounds)])[free]
        hi = np.array([np.log(b[1]) if is_log[i] and np.isfinite(b[1]) else
                       (np.inf if is_log[i] else b[1]) for i, b in enumerate(bounds)])[free]
        x0 = np.clip(to_x(theta), lo, hi)
        opt = scipy.optimize.least_squares(fun, x0, jac=jac, bounds=(lo, hi), method="trf",
                                           x_scale="jac", max_nfev=spec.max_nfev, ftol=1e-12,
                                           xtol=1e-12, gtol=1e-12)
        nfev, njev = nfev + opt.nfev, njev + (opt.njev or 0)
        theta = to_theta(opt.x)
        r, J = compute(opt.x)
        if not reweighted:
            # several measured columns without given uncertainties: weight each by its own rms
            res = (cache["model"] - problem.Y)
            problem.sigma = np.where(problem.sigma_given, problem.sigma,
                                     np.maximum(np.sqrt(np.mean(res**2, axis=0)), 1e-300))
            reweighted = True
            compute(opt.x)
            continue
        null = _null_direction(J, spec.identifiability_tol)
        if null is not None and len(free) > 1:
            hold(null)
            continue
        if reselected < 2:
            old = [None if p.z is None else p.z.copy() for p in problem.points]
            compute(opt.x, select=True)
            changed = any((o is None) != (p.z is None) or (o is not None and
                          np.max(np.abs(o - p.z)) > 1e-6) for o, p in zip(old, problem.points))
            reselected += 1
            if changed:
                continue
            compute(opt.x)
        break

    r, J = cache["r"], cache["J"]
    model = cache["model"]
    m, k = r.size, len(free)
    dof = max(m - k, 1)
    s2 = float(r @ r / dof)
    JtJ = J.T @ J
    cov_x = s2 * np.linalg.pinv(JtJ)
    tq = float(scipy.stats.t.ppf(0.5 + spec.confidence / 2.0, dof))
    colnorm = np.linalg.norm(J, axis=0)
    sv = np.linalg.svd(J / np.where(colnorm > 0, colnorm, 1.0), compute_uv=False)
    sv_rel = sv / sv[0] if sv.size and sv[0] > 0 else sv
    final_null = _null_direction(J, spec.identifiability_tol) if k else None
    if final_null is not None:  # one parameter left and still undetermined
        warnings.append(f"{names[free[0]]} is not determined by these data (its sensitivity is zero)")

    params = {}
    sd_x = np.sqrt(np.maximum(np.diag(cov_x), 0.0))
    for i, n in enumerate(names):
        lo_b, hi_b = bounds[i]
        entry = {"value": float(theta[i]), "unit": _unit(n), "initial": float(problem.initial[n]),
                 "bounds": [float(lo_b), float(hi_b)], "fitted": i in free,
                 "scale": "log" if is_log[i] else "linear", "description": PARAMETERS[n].description}
        if i in free:
            a = free.index(i)
            if is_log[i]:
                lo = theta[i] * _exp(-tq * sd_x[a])
                hi = theta[i] * _exp(tq * sd_x[a])
                std = theta[i] * sd_x[a]
            else:
                lo, hi, std = theta[i] - tq * sd_x[a], theta[i] + tq * sd_x[a], sd_x[a]
            entry.update(std=float(std), ci=[float(lo), float(hi)],
                         at_bound=bool(np.isclose(theta[i], lo_b, rtol=1e-9, atol=0) or
                                       np.isclose(theta[i], hi_b, rtol=1e-9, atol=0)))
        else:
            entry.update(std=None, ci=None, at_bound=False)
        params[n] = entry
    for c in combinations:  # intervals of the identifiable combinations (held parameter fixed)
        i_free = c.pop("_free")
        c["value"] = float(_combination_value(c, params))
        if i_free in free:
            a = free.index(i_free)
            c["ci"] = [float(c["value"] * _exp(-tq * sd_x[a])),
                       float(c["value"] * _exp(tq * sd_x[a]))]
            c["std"] = float(c["value"] * sd_x[a])
        else:
            c["ci"], c["std"] = None, None
    scale = np.where(is_log[free], theta[free], 1.0)
    cov = cov_x * scale[:, None] * scale[None, :]
    sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd, sd)
    corr = np.where(np.isfinite(corr), corr, 0.0)
    for a in range(k):
        for b in range(a + 1, k):
            if abs(corr[a, b]) > 0.99 and final_null is None:
                warnings.append(f"{names[free[a]]} and {names[free[b]]} are strongly correlated "
                                f"(correlation {corr[a, b]:+.4f}): the data barely separate them")
    derived = _derived(problem, theta, free, cov_x, tq)

    points = []
    for i in range(problem.data.n):
        pt = problem.points[i]
        row = {"row": i + 1, "line": int(problem.data.lines[i]), "converged": bool(pt.converged),
               "stable": bool(pt.stable), "morse_index": int(pt.morse_index),
               "inputs": {c: float(problem.data.columns[c][i]) for c in problem.data.inputs},
               "measured": {o: float(problem.Y[i, j]) for j, o in enumerate(problem.outputs)},
               "model": {o: float(model[i, j]) for j, o in enumerate(problem.outputs)},
               "residual": {o: float(model[i, j] - problem.Y[i, j])
                            for j, o in enumerate(problem.outputs)}}
        points.append(row)
    failed = [p["row"] for p in points if not p["converged"]]
    unstable = [p["row"] for p in points if p["converged"] and not p["stable"]]
    ok = bool(opt.success) and not failed and not unstable
    msg = f"least squares: {opt.message}"
    if failed:
        msg += f"; no converged equilibrium at data rows {failed}"
    if unstable:
        msg += f"; only unstable equilibria found at data rows {unstable}"
    for i, n in enumerate(names):
        if i in free and params[n]["at_bound"]:
            warnings.append(f"{n} = {theta[i]:.6g} sits at a bound: the interval assumes an "
                            "interior optimum; widen the bounds")
    curves = problem.curves(theta, spec.curve_points)
    return FitResult(
        success=ok, status="converged" if ok else "not_converged", message=msg,
        parameters=params, fitted_names=[names[i] for i in free], confidence=spec.confidence,
        identifiable=not held and final_null is None, warnings=warnings, combinations=combinations,
        derived=derived, covariance=cov, correlation=corr, singular_values=sv_rel, model=model,
        residuals=model - problem.Y, sigma=problem.sigma.copy(), s2=s2, dof=dof,
        optimizer={"method": "scipy.optimize.least_squares (trf)", "nfev": int(nfev),
                   "njev": int(njev), "status": int(opt.status), "message": str(opt.message),
                   "cost": float(0.5 * r @ r), "t_quantile": tq},
        points=points, curves=curves, data=problem.data, outputs=list(problem.outputs),
        name=problem.config.name or "fit", solver=problem.options.as_dict())


# -- identifiability helpers -------------------------------------------------------------------------
def _null_direction(J: np.ndarray, tol: float):
    """(null vector in the columns of J, its relative singular value, column norms), or None."""
    if J.shape[1] == 0:
        return None
    colnorm = np.linalg.norm(J, axis=0)
    if np.any(colnorm == 0):
        v = (colnorm == 0).astype(float)
        return v / np.linalg.norm(v), 0.0, colnorm
    _, s, Vt = np.linalg.svd(J / colnorm, full_matrices=False)
    rel = s[-1] / s[0]
    if rel >= tol:
        return None
    return Vt[-1] / colnorm / np.linalg.norm(Vt[-1] / colnorm), float(rel), colnorm


def _choose_held(vec: np.ndarray, colnorm: np.ndarray) -> int:
    """Index (among free) of the parameter to hold: the last with a leading null component."""
    weight = np.abs(vec) * np.where(colnorm > 0, colnorm, 1.0)
    big = np.flatnonzero(weight >= 0.5 * weight.max())
    return int(big[-1])


def _identifiability_message(names, free, vec, j, rel, is_log, problem) -> str:
    involved = [names[free[a]] for a in range(len(free)) if abs(vec[a]) > 1e-6 * np.max(np.abs(vec))]
    if len(involved) == 1:
        what = f"the data carry no information on {involved[0]}"
    else:
        what = (f"{' and '.join(involved)} are not identifiable separately from these data "
                f"(relative singular value {rel:.1e}")
        if set(involved) <= {"chi_bar", "youngs_modulus", "bending_stiffness", "h", "field_scale"}:
            what += "; they enter only through the field group h² ∝ χ̄ H²/B"
        what += ")"
    return (f"{what}: {names[j]} is held at {problem.initial[names[j]]:g} {_unit(names[j])}".rstrip()
            + " and the identifiable combination is fitted")


def _combinations(names, free, vec, j, is_log, theta) -> List[dict]:
    """Combinations invariant along the null direction, one per free parameter involved."""
    a_j = free.index(j)
    out = []
    for a, i in enumerate(free):
        if i == j or abs(vec[a]) <= 1e-6 * np.max(np.abs(vec)):
            continue
        if not (is_log[i] and is_log[j]):
            continue  # linear mixtures are reported in the warning only
        expo = -vec[a] / vec[a_j]
        e = round(expo * 6) / 6 if abs(expo * 6 - round(expo * 6)) < 1e-3 else expo
        e_txt = f"{e:g}" if float(e).is_integer() else f"{e:.4g}"
        unit = _combined_unit(_unit(names[i]), _unit(names[j]), e)
        out.append({"name": f"{names[i]} * {names[j]}^{e_txt}", "parameters": [names[i], names[j]],
                    "exponents": [1.0, float(e)], "unit": unit, "_free": i})
    return out


def _combined_unit(u1: str, u2: str, e: float) -> str:
    from .units import ureg
    try:
        u = ureg.Unit(u1 or "dimensionless") * ureg.Unit(u2 or "dimensionless") ** e
        return "" if u.dimensionless else f"{u:~P}"
    except Exception:  # noqa: BLE001 - a unit string for display only
        return f"{u1} {u2}^{e:g}".strip()


def _combination_value(c: dict, params: dict) -> float:
    (n1, n2), (e1, e2) = c["parameters"], c["exponents"]
    return params[n1]["value"] ** e1 * params[n2]["value"] ** e2


def _derived(problem: FitProblem, theta, free, cov_x, tq) -> Dict[str, dict]:
    """Physical scenes: the field coefficient c = h/H = √(μ0 χ̄ A ℓ²/(2B)) with its interval."""
    if problem.kind != "physical" or problem.scene.field is None:
        return {}
    names, c = problem.names, problem.const
    val = dict(zip(names, theta))
    chi = val.get("chi_bar", c["chi0"])
    B = (val["youngs_modulus"] / c["E0"] * c["B0"]) if "youngs_modulus" in val else \
        val.get("bending_stiffness", c["B0"])
    coef = math.sqrt(MU0 * chi * c["A"] * c["L"] ** 2 / (2.0 * B))
    # d log c / d log χ̄ = 1/2, d log c / d log E (or B) = −1/2
    g = np.array([0.5 if names[i] == "chi_bar" else
                  -0.5 if names[i] in ("youngs_modulus", "bending_stiffness") else 0.0
                  for i in free])
    sd = float(math.sqrt(max(g @ cov_x @ g, 0.0))) if g.size else 0.0
    out = {"h_per_field": {"value": coef, "unit": "m/A", "std": coef * sd,
                           "ci": [coef * _exp(-tq * sd), coef * _exp(tq * sd)],
                           "description": "h = c·H, c = sqrt(mu0 chi_bar A l^2 / (2 B))"}}
    if abs(math.cos(problem.scene.phi)) < 1e-9:
        hc = math.pi / (2.0 * math.sqrt(2.0))  # THEORY §6, transverse buckling threshold
        out["transverse_critical_field"] = {
            "value": hc / coef, "unit": "A/m", "std": hc / coef * sd,
            "ci": [hc / coef * _exp(-tq * sd), hc / coef * _exp(tq * sd)],
            "description": "H at which h = h_crit = pi/(2 sqrt 2) (phi = 90 deg, THEORY §6)"}
    return out


# -- outputs ----------------------------------------------------------------------------------------
def points_csv_text(result: FitResult) -> str:
    """Data, model and residuals per row, in the units of the data file."""
    d = result.data
    cols = ["row"] + [f"{c} [{d.units[c]}]".replace(" []", "") for c in d.inputs]
    for o in result.outputs:
        u = f" [{d.units[o]}]" if d.units[o] else ""
        cols += [f"{o}{u}", f"{o}_model{u}", f"{o}_residual{u}"]
    cols += ["stable", "converged"]
    lines = [",".join(cols)]
    for i, p in enumerate(result.points):
        vals = [str(p["row"])] + [repr(float(d.as_given(c, [p["inputs"][c]])[0])) for c in d.inputs]
        for o in result.outputs:
            vals += [repr(float(d.as_given(o, [p[key][o]])[0])) for key in ("measured", "model",
                                                                            "residual")]
        vals += [str(p["stable"]).lower(), str(p["converged"]).lower()]
        lines.append(",".join(vals))
    return "\n".join(lines) + "\n"


def write_fit(result: FitResult, out_dir, config: Optional[dict] = None) -> Dict[str, Any]:
    """Write ``fit.json``, ``fit_points.csv``, ``fit_data_vs_model.png`` and ``fit_residuals.png``
    into ``out_dir`` (each written to a temporary name, then renamed)."""
    import io
    from pathlib import Path

    from . import __version__
    from .io import atomic_write, dumps_json
    from .study.figures import fit_figures

    payload = {**result.to_dict(), "config": config, "package_version": __version__}
    text = dumps_json(payload, indent=1) + "\n"
    csv_text = points_csv_text(result)
    pngs = {}
    for name, fig in fit_figures(result).items():
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=130)
        pngs[name] = buf.getvalue()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"json": out / "fit.json", "csv": out / "fit_points.csv"}
    atomic_write(paths["json"], lambda fh: fh.write(text))
    atomic_write(paths["csv"], lambda fh: fh.write(csv_text))
    for name, data in pngs.items():
        paths[name] = atomic_write(out / f"{name}.png", lambda fh, b=data: fh.write(b), binary=True)
    return paths
