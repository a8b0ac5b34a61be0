"""Calibration: fit scene parameters to measured equilibria, with confidence intervals.

A configuration gives the scene (what is known) and a ``study:`` section of ``type: fit`` naming
the parameters to fit (:mod:`actuator_design.config.studies.fit`); a CSV file (:mod:`.data`) holds the measurements.

Fittable parameters (:data:`.parameters.PARAMETERS`): ``chi_bar`` (χ̄), ``youngs_modulus`` (E) or
``bending_stiffness`` (B0), ``remanence`` (M_r of a hard-magnetic rod, THEORY §9) — physical scenes; ``h`` (the group at ``reference_field``, or the
scene's h when the data have no field column) — dimensionless scenes; ``clamp_angle`` (θ0), ``field_scale``
(measured field × scale), ``field_offset`` (added to the measured field) and ``field_angle_offset``
(added to the field angle) — both.

Method (nested least squares with exact sensitivities)
-----------------------------------------------------
The model of every distinct measured condition is a stable equilibrium with exact sensitivities
(:mod:`.problem`, :mod:`.branches`). These Jacobians drive ``scipy.optimize.least_squares`` (trust
region, bounds; positive parameters in log scale). Every evaluation starts from the equilibria of
the lowest-cost evaluation so far, so a trial step the optimiser rejects cannot move a condition
onto another branch for the next one. Parameters the data do not determine are held
(:mod:`.identifiability`); intervals come from s² (JᵀJ)⁻¹ (:mod:`.intervals`).

A fit is a clean success only when the optimiser converged, every data point has a converged,
stable equilibrium, the data determine every fitted parameter (or a reported combination of held
ones), the fit moved from its start unless it started at an exact fit, no fitted parameter ends on
a bound, and — with the uncertainties given — the residuals pass the χ² test (:mod:`.goodness`).
Data magnitudes implausible for the scene (a unit 1000× off) are warned about (:mod:`.plausibility`).

The size of a fit is bounded (:mod:`.limits`), and SIGINT/SIGTERM stop it after the forward solve
in progress (:mod:`.interrupt`).
"""
from __future__ import annotations

import sys
from typing import Any, Dict, List

import numpy as np
import scipy.optimize
import scipy.stats

from actuator_design.calibration.data import MeasuredData, read_data
from actuator_design.calibration.goodness import (bound_failures, bound_message, chi_square_message,
                                                  chi_square_test)
from actuator_design.calibration.identifiability import (choose_held, combinations, identifiability_message,
                                                         null_direction)
from actuator_design.calibration.interrupt import FitInterrupted, stop_on_signals
from actuator_design.calibration.intervals import (combination_intervals, derived_quantities,
                                                   natural_covariance, parameter_entries)
from actuator_design.calibration.parameters import PARAMETERS
from actuator_design.calibration.plausibility import magnitude_warnings
from actuator_design.calibration.problem import FitProblem
from actuator_design.calibration.result import FitResult
from actuator_design.config.studies.fit import FitSpec
from actuator_design.config import ConfigError, load_config
from actuator_design.physics.magnetics_block import MagneticSummary
from actuator_design.physics.registry import refuse_unsupported, registered_terms
from actuator_design.config.studies.validation import validate_spec

__all__ = ["prepare_fit", "fit_config", "fit"]


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
    # the fit map (problem.FitProblem._build_map) scales a term's values by their declared power laws
    # in B0, and the groups the field drives by the magnetic material's coefficients per unit field;
    # any other term's values would be held fixed while the field or the stiffness changes, silently
    per_field = set(MagneticSummary.FORMULAS)
    supported = [c.name for c in registered_terms() if c.scaling_declared and all(
        p.slot in per_field or not (p.field_power or p.susceptibility_power) for p in c.parameters)]
    refuse_unsupported(config.to_scene(), supported, "fit")
    if isinstance(data_source, MeasuredData):
        data = data_source
    else:
        data = read_data(data_source, dimensionless=config.scene.type == "dimensionless",
                         ignore_columns=spec.ignore_columns)
    return FitProblem(config, data, spec)


def fit_config(config_source, data_source, progress: bool = False,
               interruptible: bool = True) -> FitResult:
    """:func:`prepare_fit` then :func:`fit`."""
    return fit(prepare_fit(config_source, data_source), progress=progress,
               interruptible=interruptible)


def _progress_bar(enabled: bool, total: int):
    """A tqdm bar on stderr (None when disabled)."""
    if not enabled:
        return None
    from tqdm import tqdm
    return tqdm(total=total, file=sys.stderr, unit="solve", dynamic_ncols=True, mininterval=0.5,
                desc="fit: evaluation 1")


def fit(problem: FitProblem, progress: bool = False, interruptible: bool = True) -> FitResult:
    """Least-squares fit of ``problem`` (see the module docstring for the method).

    Parameters
    ----------
    problem : FitProblem
    progress : bool
        Show a progress bar (forward solves of the current model evaluation) on stderr.
    interruptible : bool
        While the fit runs (in the main thread), SIGINT and SIGTERM stop it after the forward
        solve in progress (:mod:`.interrupt`).

    Raises
    ------
    FitInterrupted
        A SIGINT or SIGTERM arrived (a ``KeyboardInterrupt``; nothing is returned).
    """
    with stop_on_signals(interruptible) as stop:
        return _fit(problem, progress, stop)


def _fit(problem: FitProblem, progress: bool, stop) -> FitResult:
    """:func:`fit` with the stop request ``stop`` checked after every forward solve."""
    spec = problem.spec
    names = problem.names
    k_all = len(names)
    theta = np.array([problem.initial[n] for n in names], float)
    free = list(range(k_all))
    held: Dict[int, str] = {}
    undetermined: List[str] = []
    warnings: List[str] = magnitude_warnings(problem)
    n_magnitude = len(warnings)
    combos: List[dict] = []
    is_log = np.array([PARAMETERS[n].log for n in names])
    bounds = [spec.bounds_of(n) for n in names]
    reweighted = bool(np.all(problem.sigma_given)) or len(problem.outputs) == 1
    reselected = 0
    cache: Dict[str, Any] = {}
    n_res = problem.data.n * len(problem.outputs)
    root_w = np.sqrt(problem.weights)[:, None]  # (n, 1): rows weigh in the sum of squares
    bar = _progress_bar(progress, problem.n_conditions)
    n_eval = 0
    # the tracked equilibria of the lowest cost evaluated (the optimiser's iterate): every
    # evaluation starts from these, not from the last trial's (see compute)
    best: Dict[str, Any] = {"cost": np.inf, "states": None}

    def check_stop():
        if stop.requested:
            raise FitInterrupted(f"fit stopped during model evaluation {n_eval}, after "
                                 f"{problem.n_solves} forward solves ({problem.n_conditions} "
                                 "per evaluation); no result")

    def solved_one():
        """After each forward solve: stop on a signal, advance the bar."""
        check_stop()
        if bar is not None:
            bar.update()

    def to_x(th):
        return np.where(is_log, np.log(np.maximum(th, 1e-300)), th)[free]

    def to_theta(x):
        th = theta.copy()
        th[free] = np.where(is_log[free], np.exp(x), x)
        return th

    def compute(x, select=False, anchor=True):
        """Residuals and Jacobian at ``x``, warm-started from the best evaluation's equilibria.

        A trial step of the optimiser that is rejected must not move the tracked equilibria:
        near a branch point a step across the symmetric configuration (e.g. the sign of the clamp
        angle) makes a branch vanish, Newton lands on the other one, and the next trial would
        continue that wrong branch where both exist again. So the equilibria of an evaluation are
        kept only when it lowers the cost (an accepted step) or when it is an ``anchor`` (the
        fit's own evaluations: branch selection, holding a parameter, re-weighting).
        """
        nonlocal n_eval
        n_eval += 1
        if best["states"] is not None:
            problem.restore(best["states"])
        if bar is not None:
            bar.reset(total=problem.n_conditions)
            bar.set_description(f"fit: evaluation {n_eval}" + (" (choosing branches)"
                                                                if select else ""))
        th = to_theta(x)
        model, jac = problem.evaluate(th, select=select, progress=solved_one)
        w = root_w / problem.sigma[None, :]  # (n, n_out)
        r = ((model - problem.Y) * w).T.ravel()  # output-major
        Jn = (jac * w[:, :, None]).transpose(1, 0, 2).reshape(n_res, -1)[:, free]
        Jx = Jn * np.where(is_log[free], th[free], 1.0)[None, :]  # d/dlog p = p d/dp
        cache.update(x=np.array(x), r=r, J=Jx, model=model)
        cost = 0.5 * float(r @ r)
        if anchor or cost < best["cost"]:
            best.update(cost=cost, states=problem.snapshot())
        if bar is not None:
            bar.set_postfix(cost=f"{cost:.4g}", refresh=False)
        return r, Jx

    def fun(x):
        if "x" in cache and np.array_equal(cache["x"], x):
            return cache["r"]
        return compute(x, anchor=False)[0]

    def jac(x):
        if "x" in cache and np.array_equal(cache["x"], x):
            return cache["J"]
        return compute(x, anchor=False)[1]

    def hold(null) -> None:
        """Hold the parameter the null direction leans on most; record the message."""
        nonlocal free
        vec, rel, colnorm = null
        j = free[choose_held(vec, colnorm)]
        found = combinations(names, free, vec, j, is_log, theta)
        warnings.append(identifiability_message(names, free, vec, j, rel, is_log, problem,
                                                combined=bool(found)))
        if not found:  # no information on it, or a mixture that is not reported: undetermined
            involved = np.abs(vec) > 1e-6 * np.max(np.abs(vec))
            undetermined.extend(names[free[a]] for a in np.flatnonzero(involved))
        combos.extend(found)
        held[j] = names[j]
        free = [i for i in free if i != j]
        theta[j] = problem.initial[names[j]]
        compute(to_x(theta))

    try:
        # first evaluation: choose every condition's branch at the initial guess
        compute(to_x(theta), select=True)
        # a structural degeneracy (proportional sensitivities, e.g. χ̄ and E through h² only)
        # shows already here; a zero sensitivity may be accidental (all points below a threshold)
        null = null_direction(cache["J"], spec.identifiability_tol)
        while null is not None and len(free) > 1 and null[1] < 1e-10 and np.all(null[2] > 0):
            hold(null)
            null = null_direction(cache["J"], spec.identifiability_tol)
        opt = None
        nfev = njev = 0
        for _round in range(3 * k_all + 6):
            lo = np.array([np.log(b[0]) if is_log[i] and b[0] > 0 else
                           (-np.inf if is_log[i] else b[0]) for i, b in enumerate(bounds)])[free]
            hi = np.array([np.log(b[1]) if is_log[i] and np.isfinite(b[1]) else
                           (np.inf if is_log[i] else b[1]) for i, b in enumerate(bounds)])[free]
            x0 = np.clip(to_x(theta), lo, hi)
            if not np.array_equal(cache.get("x"), x0):
                compute(x0)  # the optimiser's first iterate: its equilibria are the warm start
            opt = scipy.optimize.least_squares(fun, x0, jac=jac, bounds=(lo, hi), method="trf",
                                               x_scale="jac", max_nfev=spec.max_nfev, ftol=1e-12,
                                               xtol=1e-12, gtol=1e-12)
            nfev, njev = nfev + opt.nfev, njev + (opt.njev or 0)
            theta = to_theta(opt.x)
            r, J = compute(opt.x)
            if not reweighted:
                # several measured columns without given uncertainties: weight each by its own rms
                res = cache["model"] - problem.Y
                rms = np.sqrt(np.average(res**2, axis=0, weights=problem.weights))
                problem.sigma = np.where(problem.sigma_given, problem.sigma,
                                         np.maximum(rms, 1e-300))
                reweighted = True
                compute(opt.x)
                continue
            null = null_direction(J, spec.identifiability_tol)
            if null is not None and len(free) > 1:
                hold(null)
                continue
            if reselected < 2:
                old = [None if s.z is None else s.z.copy() for s in problem.states]
                compute(opt.x, select=True)
                changed = any((o is None) != (s.z is None) or (o is not None and
                              np.max(np.abs(o - s.z)) > 1e-6) for o, s in zip(old, problem.states))
                reselected += 1
                if changed:
                    continue
                compute(opt.x)
            break
    finally:
        if bar is not None:
            bar.close()
    result = _result(problem, theta, free, held, undetermined, warnings, combos, is_log, bounds,
                     cache, opt, nfev, njev, n_eval, n_magnitude)
    check_stop()  # a signal during the model curves
    return result


def _result(problem, theta, free, held, undetermined, warnings, combos, is_log, bounds, cache,
            opt, nfev, njev, n_eval, n_magnitude=0) -> FitResult:
    """Intervals, identifiability verdict, status and per-row points of a finished fit."""
    spec, names = problem.spec, problem.names
    r, J, model = cache["r"], cache["J"], cache["model"]
    m, k = r.size, len(free)
    dof = max(m - k, 1)
    s2 = float(r @ r / dof)
    cov_x = s2 * np.linalg.pinv(J.T @ J)
    tq = float(scipy.stats.t.ppf(0.5 + spec.confidence / 2.0, dof))
    colnorm = np.linalg.norm(J, axis=0)
    sv = np.linalg.svd(J / np.where(colnorm > 0, colnorm, 1.0), compute_uv=False)
    sv_rel = sv / sv[0] if sv.size and sv[0] > 0 else sv
    final_null = null_direction(J, spec.identifiability_tol) if k else None
    if final_null is not None:  # one parameter left and still undetermined
        warnings.append(f"{names[free[0]]} is not determined by these data (its sensitivity is "
                        "zero)")
        undetermined.append(names[free[0]])
    sd_x = np.sqrt(np.maximum(np.diag(cov_x), 0.0))
    params = parameter_entries(names, theta, problem.initial, bounds, free, is_log, sd_x, tq,
                               active=getattr(opt, "active_mask", None))
    combination_intervals(combos, params, free, sd_x, tq)
    cov, corr = natural_covariance(cov_x, theta[free], is_log[free])
    for a in range(k):
        for b in range(a + 1, k):
            if abs(corr[a, b]) > 0.99 and final_null is None:
                warnings.append(f"{names[free[a]]} and {names[free[b]]} are strongly correlated "
                                f"(correlation {corr[a, b]:+.4f}): the data barely separate them")
    derived = derived_quantities(problem, theta, free, cov_x, tq)
    points = _points(problem, model)
    for i, n in enumerate(names):
        if i in free and params[n]["at_bound"]:
            warnings.append(f"{n} = {theta[i]:.6g} sits at a bound: the interval assumes an "
                            "interior optimum; widen the bounds")
    gof = chi_square_test(r, k, bool(np.all(problem.sigma_given)), spec.min_p_value)
    status, ok, msg = _status(problem, opt, points, theta, free, undetermined, r, J)
    at_bounds = bound_failures(params)
    if at_bounds:
        msg += "; " + bound_message(at_bounds)
        status, ok = (status, ok) if not ok else ("at_bound", False)
    if gof["passed"] is False:
        d = problem.data
        rms = {o: float(np.sqrt(np.mean(d.as_given(o, (model - problem.Y)[:, j]) ** 2)))
               for j, o in enumerate(problem.outputs)}
        sigma = {o: float(d.as_given(o, [problem.sigma[j]])[0])
                 for j, o in enumerate(problem.outputs)}
        hint = ("see the warning on the data's magnitudes" if n_magnitude else None)
        msg += "; " + chi_square_message(gof, rms, d.units, sigma, hint)
        status, ok = (status, ok) if not ok else ("poor_fit", False)
    return FitResult(
        success=ok, status=status, message=msg,
        parameters=params, fitted_names=[names[i] for i in free], confidence=spec.confidence,
        identifiable=not held and final_null is None, warnings=warnings, combinations=combos,
        derived=derived, covariance=cov, correlation=corr, singular_values=sv_rel, model=model,
        residuals=model - problem.Y, sigma=problem.sigma.copy(), s2=s2, dof=dof,
        optimizer={"method": "scipy.optimize.least_squares (trf)", "nfev": int(nfev),
                   "njev": int(njev), "status": int(opt.status), "message": str(opt.message),
                   "cost": float(0.5 * r @ r), "t_quantile": tq, "evaluations": int(n_eval),
                   "conditions": problem.n_conditions, "forward_solves": int(problem.n_solves)},
        points=points, curves=problem.curves(theta, spec.curve_points), data=problem.data,
        outputs=list(problem.outputs), name=problem.config.name or "fit",
        solver=problem.options.as_dict(), goodness_of_fit=gof)


def _points(problem, model) -> List[dict]:
    """Per data row: inputs, measured, model, residual, and its condition's equilibrium state."""
    d, out = problem.data, []
    for i in range(d.n):
        st = problem.state_of_row(i)
        out.append({"row": i + 1, "line": int(d.lines[i]), "converged": bool(st.converged),
                    "stable": bool(st.stable), "morse_index": int(st.morse_index),
                    "inputs": {c: float(d.columns[c][i]) for c in d.inputs},
                    "measured": {o: float(problem.Y[i, j]) for j, o in enumerate(problem.outputs)},
                    "model": {o: float(model[i, j]) for j, o in enumerate(problem.outputs)},
                    "residual": {o: float(model[i, j] - problem.Y[i, j])
                                 for j, o in enumerate(problem.outputs)}})
    return out


def _status(problem, opt, points, theta, free, undetermined, r, J):
    """(status, success, message): the first failure among not converged, not identifiable and
    did not move; the message names every failure found."""
    msg = f"least squares: {opt.message}"
    status = None
    failed = [p["row"] for p in points if not p["converged"]]
    unstable = [p["row"] for p in points if p["converged"] and not p["stable"]]
    if failed:
        msg += f"; no converged equilibrium at data rows {_rows(failed)}"
    if unstable:
        msg += f"; only unstable equilibria found at data rows {_rows(unstable)}"
    if not opt.success or failed or unstable:
        status = "not_converged"
    if undetermined:
        names = ", ".join(dict.fromkeys(undetermined))
        msg += (f"; not identifiable: the data do not determine {names} (no or dependent "
                f"sensitivities at the {problem.n_conditions} distinct measured condition(s))")
        status = status or "not_identifiable"
    initial = np.array([problem.initial[n] for n in problem.names])
    moved = not np.allclose(theta[free], initial[free], rtol=1e-9, atol=1e-12)
    # a start that is already the least-squares optimum (zero gradient Jᵀr with a well-conditioned
    # J, e.g. data symmetric about it) is a fit that needed no step
    optimal_start = (null_direction(J, problem.spec.identifiability_tol) is None and
                     np.linalg.norm(J.T @ r) <= 1e-8 * np.linalg.norm(J) * np.linalg.norm(r))
    if not moved and not optimal_start and float(r @ r) > 1e-20 * max(r.size, 1):
        msg += ("; did not move: the fitted values are the initial values, with residuals left "
                "(no descent direction there: try other initial values or more varied data)")
        status = status or "did_not_move"
    return status or "converged", status is None, msg


def _rows(rows: List[int], limit: int = 20) -> str:
    """A list of row numbers for a message (at most ``limit`` shown)."""
    shown = ", ".join(str(i) for i in rows[:limit])
    return f"[{shown}{', …' if len(rows) > limit else ''}] ({len(rows)} rows)" \
        if len(rows) > limit else f"[{shown}]"
