"""The calibration problem: measured conditions → scenes → stable equilibria → model outputs.

For each distinct condition c (field H, field angle, load of a data row) and fitted parameters θ,
the dimensionless groups of THEORY §5 (h² = μ0 χ̄ H² A ℓ²/(2B), p = P ℓ²/B, …) fill the slots q of
the NLP parameter vector of the solver built once for the scene structure; a hard-magnetic rod adds
h_r = μ0 M_r H A ℓ²/B (THEORY §9), linear in the field and in 1/B. The equilibrium z_c is
found by damped Newton, warm-started from the condition's solution at the best parameters
evaluated so far (:meth:`FitProblem.snapshot`; a trial step the optimiser rejects leaves no trace)
or, the first time, along the conditions sorted by their inputs, on the stable branch closest to
the measurements (:mod:`.branches`). Rows that share a condition share one forward solve and one
sensitivity: the branch is chosen against the (weighted) mean of their measurements, which ranks
branches exactly as the sum of their squared residuals does.

The tip y = T(z, q) depends on q directly and through z(q), defined by ∇_r Ê(z, q) = 0; the
implicit function theorem gives dz/dq = −H_r⁻¹ ∂(∇_r Ê)/∂q, so dy/dθ = (∂T/∂z dz/dq + ∂T/∂q) dq/dθ
with q(θ) an explicit CasADi map.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Callable, List, Optional, Tuple

import casadi as ca
import numpy as np

from actuator_design.calibration import limits as fit_limits
from actuator_design.calibration.branches import BranchSelector
from actuator_design.calibration.curves import model_curves
from actuator_design.calibration.data import COLUMNS, DataError, MeasuredData
from actuator_design.calibration.parameters import OUTPUT_COMPONENT, PARAMETERS, alternatives
from actuator_design.config.studies.fit import FitSpec
from actuator_design.config import ConfigError
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.solver import EquilibriumSolver, get_solver
from actuator_design.model.scene import Scene, UniformField
from actuator_design.model.units import QuantityError, parse_quantity
from actuator_design.physics.magnetics_block import MagneticSummary
from actuator_design.physics.parameters import field_groups, get_value
from actuator_design.physics.parameters import parameter as get_parameter
from actuator_design.physics.parameters import stiffness_groups
from actuator_design.physics.registry import build_terms
from actuator_design.physics.term_protocol import scalar_parameter_values
from actuator_design.config.studies.validation import validate_spec

__all__ = ["FitProblem", "ConditionState"]


@dataclass
class ConditionState:
    """The tracked equilibrium of one distinct condition (warm start of the next evaluation)."""

    z: Optional[np.ndarray] = None
    converged: bool = False
    stable: bool = False
    morse_index: int = -1
    #: dz_r/dθ at ``z`` (shape (n_nodes − 1, k)) and the θ it was computed at: a first-order
    #: predictor of the next evaluation's equilibrium (None when unknown)
    dz_dtheta: Optional[np.ndarray] = None
    theta: Optional[np.ndarray] = None


class FitProblem:
    """Measured data, the map θ → NLP parameters, and the equilibrium solver of the structure.

    Parameters
    ----------
    config : Config
        Validated configuration (``actuator_design.config.load_config``); its ``study`` section is
        the fit specification.
    data : MeasuredData
    spec : FitSpec, optional
        The validated ``study`` section (validated from ``config`` when omitted).

    Attributes
    ----------
    U : ndarray, shape (n, 4)
        Inputs of each row: H, field angle, Fx, Fy (SI, or dimensionless loads).
    conditions : ndarray, shape (n_c, 4)
        The distinct rows of ``U``; ``row_condition[i]`` is the condition of row i.
    Y : ndarray, shape (n, n_out)
        Measured outputs, SI.
    weights : ndarray, shape (n,)
        Row weights (1 unless the data give them).
    sigma : ndarray, shape (n_out,)
        Scale of each output's residual (given uncertainty, or re-estimated by the fit).
    states : list of ConditionState
        One per distinct condition.
    n_solves : int
        Number of condition solves so far (one per condition per evaluation).

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
        self._build_map()
        self._prepare_conditions()
        self.selector = BranchSelector(self.solver, self.slot_index, self.comp, self.out_scale)
        self.base_params = self.solver.parameter_vector(self.scene)
        self.n_solves = 0

    # -- checks ---------------------------------------------------------------------------------
    def _check_data(self) -> None:
        cols, spec, src = self.data.columns, self.spec, self.data.source
        for name in self.names:
            if self.kind not in PARAMETERS[name].scenes:
                hint = " / ".join(alternatives(name, self.kind, getattr(self.config.scene, "rod", None)))
                raise ConfigError(f"study.parameters.{name}", f"cannot be fitted in a {self.kind} scene"
                                  + (f" (fit {hint} instead)" if hint else ""))
        if self.kind == "physical":
            rod = self.config.scene.rod
            if "youngs_modulus" in self.names and rod.youngs_modulus is None:
                raise ConfigError("study.parameters.youngs_modulus",
                                  "the scene gives rod.bending_stiffness: fit bending_stiffness")
            if "bending_stiffness" in self.names and rod.bending_stiffness is None:
                raise ConfigError("study.parameters.bending_stiffness",
                                  "the scene gives rod.youngs_modulus: fit youngs_modulus")
            material = self._material()
            for name in self.names:
                if PARAMETERS[name].material and getattr(material, name) is None:
                    raise ConfigError(f"study.parameters.{name}",
                                      f"the scene has no {PARAMETERS[name].description}: give "
                                      f"scene.magnetics.{name} (a starting value) to fit it")
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
        inputs = [cols[c] for c in self.data.inputs]
        n_conditions = len(np.unique(np.column_stack(inputs), axis=0)) if inputs else 1
        if n_conditions > fit_limits.MAX_CONDITIONS:
            raise DataError(f"{src}: {n_conditions} distinct measured conditions: a fit is limited "
                            f"to {fit_limits.MAX_CONDITIONS} (one forward solve each per model "
                            "evaluation; average repeated measurements or thin the data)")
        n_meas = self.data.n * len(self.data.outputs)
        if n_meas <= len(self.names):
            raise DataError(f"{src}: {self.data.n} data point(s) with {len(self.data.outputs)} "
                            f"measured output(s) cannot determine {len(self.names)} parameter(s) "
                            "with uncertainties: give more measurements than parameters")

    def _structure_scene(self, scene: Scene) -> Scene:
        """The scene with the terms the data need (a tip force for load columns)."""
        cols = self.data.columns
        field_term = get_parameter("h").term  # the field magnitude's
        needs_field = ("field" in cols or "field_angle" in cols or
                       any(PARAMETERS[n].term == field_term for n in self.names))
        if scene.field is not None and not isinstance(scene.field, UniformField):
            raise ConfigError("scene.field", f"fitting supports uniform fields (or none), got a "
                                             f"{scene.field.kind} field")
        if needs_field and scene.field is None:
            raise ConfigError("scene.field", "the fit involves the field (a field column or a field "
                                             "parameter): give the scene a uniform field")
        if {"load", "load_x", "load_y"} & set(cols):
            scene = get_parameter("fy").require(scene)  # the load columns set its slots
        return scene

    def _material(self):
        """The rod's magnetic material (:class:`MagneticSummary`; χ̄ = χ̂ = 0 without magnetics)."""
        return self.config.scene.magnetics_summary() or MagneticSummary.nonmagnetic()

    def _constants(self) -> None:
        """Known values the map θ → NLP parameters needs (SI; B0 = 1 for dimensionless)."""
        sc, c = self.scene, {}
        if self.kind == "physical":
            rod = self.config.scene.rod
            c["L"], c["A"], c["B0"] = rod.length, rod.cross_section_area, rod.clamp_stiffness
            c["E0"] = rod.youngs_modulus
            c["H0"] = sc.scales.field
            self.material = self._material()
        else:
            c["L"], c["B0"] = 1.0, 1.0
            c["Href"] = (parse_quantity(self.spec.reference_field, "magnetic_field",
                                        "reference_field")
                         if self.spec.reference_field is not None else None)
            if c["Href"] is not None and c["Href"] <= 0:
                raise ConfigError("study.reference_field", f"must be > 0, got "
                                                           f"{self.spec.reference_field!r}")
        c["phi0"], c["theta00"] = sc.phi, sc.theta0
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
        """The value the scene has of fitted parameter ``name`` (its default starting value)."""
        p = PARAMETERS[name]
        if p.same_as is not None:  # a value of the scene itself (h, the clamp angle θ0)
            return get_value(self.scene, p.same_as)
        if p.stiffness:  # B0 = E I: the rod's
            return self.const["E0"] if name == "youngs_modulus" else self.const["B0"]
        if p.material:
            return float(getattr(self.material, name) or 0.0)
        return 1.0 if p.log else 0.0  # the field's measurement model: a factor 1, an offset 0

    # -- the map θ, inputs → NLP slots -----------------------------------------------------------
    def _build_map(self) -> None:
        """The CasADi map (θ, inputs u) → NLP slots q and dq/dθ (THEORY §5 groups)."""
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
        B_rel = self.stiffness_ratio(v)
        ratio = 1.0 / B_rel  # dimensionless loads scale with 1/B
        # the NLP slots a fit may change (lens slots; others keep the scene's value)
        slot_expr = {"phi": (u[1] if "field_angle" in cols else c["phi0"]) + get("field_angle_offset", 0.0),
                     "theta0": get("clamp_angle", c["theta00"])}
        slot_expr.update(self._field_group_map(v, H))
        if self.kind == "physical":
            scale_F = c["L"] ** 2 / (c["B0"] * B_rel)  # a measured load in N, p = P ℓ²/B
        else:
            scale_F = 1.0
        if "load_x" in cols:
            slot_expr["fx"] = u[2] * scale_F
        if "load" in cols or "load_y" in cols:
            slot_expr["fy"] = u[3] * scale_F
        scene_slots = scalar_parameter_values(build_terms(self.scene), self.scene)
        for slot, e in stiffness_groups():  # a plug-in term's values ∝ B^e follow a fitted stiffness
            if slot not in slot_expr and slot in scene_slots:
                slot_expr[slot] = scene_slots[slot] * ratio ** (-e)
        self.slots = [s for s in slot_expr if s in layout.slices]
        self.slot_index = np.array([layout.slices[s].start for s in self.slots])
        q = ca.vertcat(*[ca.SX(slot_expr[s]) for s in self.slots])
        self.f_map = ca.Function("fit_map", [th, u], [q, ca.jacobian(q, th)])

    def stiffness_ratio(self, values: dict):
        """B / B0 at fitted ``values`` (numbers or CasADi symbols; 1 without a fitted E or B0)."""
        fitted = [n for n in values if PARAMETERS[n].stiffness]
        return values[fitted[0]] / self._scene_value(fitted[0]) if fitted else 1.0

    def field_coefficients(self, values: dict) -> dict:
        """A physical scene's groups per unit applied field, g = c_g H^f, by lens name (h, h_r, …),
        at fitted ``values`` (by name; numbers or CasADi symbols): ``MagneticSummary.coefficients``
        with the fitted material numbers and B/B0 (THEORY §5, §9)."""
        c, material = self.const, {n: x for n, x in values.items() if PARAMETERS[n].material}
        return self.material.coefficients(material, c["A"], c["L"], c["B0"], self.stiffness_ratio(values))

    def _field_group_map(self, v: dict, H) -> dict:
        """The groups the field drives (:func:`field_groups`) by NLP slot, of the fitted values ``v``
        and the field ``H`` (None: a dimensionless scene's own): c_g H^f (:meth:`field_coefficients`),
        or a dimensionless scene's value (or the fitted one) times (H / H_ref)^f."""
        out, layout = {}, self.solver.layout
        coefs = self.field_coefficients(v) if self.kind == "physical" else {}
        for p, f in field_groups():
            field = None if H is None else (H if f == 1 else H ** f)
            if p.slot not in layout.slices:
                continue
            if self.kind == "physical" and p.name in coefs:
                out[p.slot] = coefs[p.name] * field
            elif self.kind != "physical":
                given = [n for n in v if PARAMETERS[n].same_as == p.name]
                base = v[given[0]] if given else p.get(self.scene)
                out[p.slot] = base if field is None else base * field / self.const["Href"] ** f
        return out

    def _prepare_conditions(self) -> None:
        d = self.data
        U = np.zeros((d.n, 4))
        for j, name in enumerate(("field", "field_angle", "load_x", None)):
            if name in d.columns:
                U[:, j] = d.columns[name]
        for name in ("load", "load_y"):
            if name in d.columns:
                U[:, 3] = d.columns[name]
        self.U = U
        self.conditions, inverse = np.unique(U, axis=0, return_inverse=True)
        self.row_condition = np.asarray(inverse).ravel()
        C = self.conditions
        # warm starts help along sorted conditions: field angle, then field, then loads
        self.order = np.lexsort((C[:, 2], C[:, 3], C[:, 0], C[:, 1]))
        self.outputs = d.outputs
        self.Y = np.column_stack([d.columns[o] for o in self.outputs])  # (n, n_out), SI
        self.weights = np.ones(d.n) if d.weights is None else np.asarray(d.weights, float)
        counts = np.bincount(self.row_condition, weights=self.weights, minlength=len(C))
        # weighted mean measurement of each condition: picks the branch (module docstring)
        self.Y_condition = np.column_stack([
            np.bincount(self.row_condition, weights=self.weights * self.Y[:, j], minlength=len(C))
            for j in range(self.Y.shape[1])]) / counts[:, None]
        self.comp = [OUTPUT_COMPONENT[o][0] for o in self.outputs]
        self.out_scale = np.array([self.const["L"] if (OUTPUT_COMPONENT[o][1] and
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
        self.states = [ConditionState() for _ in range(len(C))]
        self.f_map_all = self.f_map.map(len(C))
        self._batch = None

    @property
    def n_conditions(self) -> int:
        """Number of distinct conditions (forward solves per evaluation)."""
        return int(self.conditions.shape[0])

    def state_of_row(self, i: int) -> ConditionState:
        """The tracked equilibrium of data row ``i`` (0-based)."""
        return self.states[int(self.row_condition[i])]

    def snapshot(self) -> List[ConditionState]:
        """A copy of the tracked equilibria of all conditions (for :meth:`restore`)."""
        return [dataclasses.replace(s) for s in self.states]

    def restore(self, snapshot: List[ConditionState]) -> None:
        """Track the equilibria of ``snapshot`` (from :meth:`snapshot`) again."""
        self.states = [dataclasses.replace(s) for s in snapshot]

    # -- evaluation -----------------------------------------------------------------------------
    def nlp_params(self, theta: np.ndarray, u: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """NLP parameter vector for inputs ``u`` (shape (4,)), and d(slots)/dθ (n_slots, k)."""
        q, dq = self.f_map(theta, u)
        P = self.base_params.copy()
        P[self.slot_index] = np.asarray(q, float).ravel()
        return P, np.asarray(dq, float).reshape(len(self.slots), -1)

    @staticmethod
    def _predicted(st: ConditionState, theta: np.ndarray) -> np.ndarray:
        """Warm start for ``theta``: the tracked equilibrium moved along dz/dθ (first order),
        unless that step is not small against the rod's deflection (near a bifurcation the
        tangent can point across branches); then the tracked equilibrium itself."""
        if st.dz_dtheta is None:
            return st.z
        step = st.dz_dtheta @ (np.asarray(theta, float) - st.theta)
        if not np.max(np.abs(step)) <= 0.1 * max(np.max(np.abs(st.z[1:] - st.z[0])), 1e-3):
            return st.z
        start = st.z.copy()
        start[1:] += step
        return start

    def _condition_params(self, c: int, theta: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """:meth:`nlp_params` of condition ``c``, from the batch of the current evaluation."""
        batch = self._batch
        if batch is not None and np.array_equal(batch[0], theta):
            P = self.base_params.copy()
            P[self.slot_index] = batch[1][:, c]
            return P, batch[2][c]
        return self.nlp_params(theta, self.conditions[c])

    def _slots_of_all_conditions(self, theta: np.ndarray) -> None:
        """Slots q (n_slots, n_c) and dq/dθ (n_c, n_slots, k) of all conditions: one CasADi call."""
        n_c, n_s = self.n_conditions, len(self.slots)
        q, dq = self.f_map_all(theta, self.conditions.T)
        dq = np.asarray(dq, float).reshape(n_s, n_c, -1).transpose(1, 0, 2)
        self._batch = (np.array(theta, float), np.asarray(q, float).reshape(n_s, n_c), dq)

    def target_misfit(self, y: np.ndarray) -> Callable[[np.ndarray], float]:
        """outputs → weighted squared distance from the measurement ``y`` (shape (n_out,))."""
        w = 1.0 / self.sigma
        return lambda out: float(np.sum(((out - y) * w) ** 2))

    def solve_condition(self, c: int, theta: np.ndarray, select: bool,
                        z_prev: Optional[np.ndarray], jacobian: bool):
        """Equilibrium, outputs and (optionally) sensitivities of condition ``c``.

        ``select``: re-choose the branch (closest stable equilibrium to the measurements) from
        the previous condition's solution ``z_prev``, its mirror image, the tracked solution and
        the straight rod; otherwise continue the tracked solution.

        Returns
        -------
        z : ndarray, shape (n_nodes,)
        outputs : ndarray, shape (n_out,), SI
        jacobian : ndarray, shape (n_out, k), or None
        """
        self.n_solves += 1
        sel = self.selector
        P, dq = self._condition_params(c, theta)
        st = self.states[c]
        if jacobian and not select and st.z is not None:
            # the usual step of a fit: continue the tracked equilibrium; one Cholesky factor of
            # H_r proves it stable and gives its sensitivities
            raw = sel.converge(self._predicted(st, theta), P)
            if raw.converged:
                found = sel.stable_sensitivity(raw.z, P, dq)
                if found is not None:
                    out, jac, dz_dtheta = found
                    st.z, st.converged, st.stable, st.morse_index = raw.z, True, True, 0
                    st.dz_dtheta, st.theta = dz_dtheta, np.array(theta, float)
                    return raw.z, out, jac
        st.dz_dtheta = st.theta = None
        misfit = self.target_misfit(self.Y_condition[c])
        straight = sel.straight(P)
        mirror = [] if z_prev is None else [z_prev, 2.0 * straight - z_prev]
        if st.z is not None and not select:
            starts = [st.z]
        else:
            starts = mirror + ([st.z] if st.z is not None else []) + [straight]
        best = sel.best(starts, P, misfit)
        if best is None or best[0][0]:
            # the tracked start failed or stayed unstable: fall back to the wider set of starts
            best = sel.best(mirror + [straight], P, misfit, incumbent=best)
        if best is None:
            st.converged, st.stable, st.morse_index = False, False, -1
            z = st.z if st.z is not None else straight
            out = sel.verdict_free_outputs(z, P)
        else:
            _, z, verdict, out = best
            st.z, st.converged = z, True
            st.stable, st.morse_index = verdict.accepted, verdict.morse_index
        jac = None
        if jacobian:
            out, jac = sel.sensitivity(z, P, dq)
        return z, out, jac

    def evaluate_conditions(self, theta: np.ndarray, select: bool = False, jacobian: bool = True,
                            progress=None):
        """Model outputs (n_c, n_out) in SI and their Jacobian (n_c, n_out, k) in natural units,
        one forward solve per distinct condition. ``progress``: called once per condition."""
        n_c, k = self.n_conditions, len(self.names)
        self._slots_of_all_conditions(theta)
        model = np.zeros((n_c, len(self.outputs)))
        jac = np.zeros((n_c, len(self.outputs), k)) if jacobian else None
        z_prev = None
        for c in self.order:
            z, out, dj = self.solve_condition(int(c), theta, select, z_prev, jacobian)
            model[c] = out
            if jacobian:
                jac[c] = dj
            z_prev = z
            if progress is not None:
                progress()
        return model, jac

    def evaluate(self, theta: np.ndarray, select: bool = False, jacobian: bool = True,
                 progress=None):
        """Model outputs (n, n_out) in SI, and their Jacobian (n, n_out, k) in natural units,
        per data row (rows sharing a condition share its values).

        ``select``: re-choose every condition's branch (closest stable equilibrium to the data).
        """
        model, jac = self.evaluate_conditions(theta, select, jacobian, progress)
        rows = self.row_condition
        return model[rows], (jac[rows] if jacobian else None)

    def curves(self, theta: np.ndarray, n_points: int):
        """Model curves along the primary input (see :func:`.curves.model_curves`)."""
        return model_curves(self, theta, n_points)
