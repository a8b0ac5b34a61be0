"""Refit a published experiment: the hard-magnetic cantilever of Zhao et al. (JMPS 2019).

Zhao, Kim, Chester, Sharma & Zhao, "Mechanics of hard-magnetic soft materials", J. Mech. Phys.
Solids 124 (2019) 244-263: a cantilever (L = 17.2 mm, t = 0.84 mm) magnetised along its length
(B_r = μ0 M_r = 0.143 T) in a uniform field anti-parallel to its magnetisation; its maximum
deflection δ/L at B = 5 ... 40 mT, digitised from the paper's figure (±0.01), is in
problems/data/zhao2019_cantilever.csv and the fit in configs/fit_zhao2019.yaml.

This script

1. fits Young's modulus E (one parameter) through the Python API and prints E with its 95 %
   interval, the rms residual and the model at each data point;
2. prints the model's buckling field B_c: the straight rod in an anti-parallel field buckles at
   h_r = π²/4 (THEORY §9), h_r = c_r H with the fitted c_r = μ0 M_r A ℓ²/B, so
   B_c = μ0 (π²/4)/c_r;
3. prints the sensitivity at 5 mT. That point sits just above the buckling field (B_c ≈ 4.5 mT),
   where δ/L ∝ √(B − B_c) for the perfect rod and a small imperfection matters: the script
   re-solves it (forward ``solve``) with the field tilted off anti-parallel by 0.5°, 1° and 2°
   (towards and against the measured, upward, side), and at the ends of E's interval; and refits
   E without the 5 mT point;
4. writes ``zhao2019_fit.png`` (measured δ/L with ±0.01 error bars and the fitted curve against
   B in mT) into OUT_DIR (default: a new temporary directory; never into the repository).

Run:  python problems/zhao2019_refit.py [OUT_DIR]
"""
from __future__ import annotations

import argparse
import copy
import math
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "configs" / "fit_zhao2019.yaml"
DATA = ROOT / "problems" / "data" / "zhao2019_cantilever.csv"
MU0 = 4e-7 * math.pi
L = 17.2e-3  # rod length (m), as in the config
SIGMA = 0.01  # digitising uncertainty of δ/L
IMPERFECTIONS_DEG = (0.5, 1.0, 2.0)


def fitted(config=CONFIG, data=DATA):
    """The fit of the shipped config and data (:class:`actuator_design.FitResult`)."""
    from actuator_design.calibration import fit_config
    return fit_config(config, data, interruptible=False)


def buckling_field_mT(result) -> dict:
    """B_c = μ0 (π²/4) / c_r (mT) from the fitted c_r = h_r/H, with its interval."""
    c = result.derived["h_r_per_field"]
    to_mT = lambda cr: 1e3 * MU0 * (math.pi ** 2 / 4.0) / cr  # noqa: E731
    return {"value": to_mT(c["value"]), "ci": sorted([to_mT(c["ci"][0]), to_mT(c["ci"][1])])}


def scene_config(youngs_modulus: float, field_mT: float, angle_deg: float = 180.0) -> dict:
    """The config's scene at E (Pa), B (mT) and field angle (deg), as a config dict."""
    import yaml
    raw = yaml.safe_load(CONFIG.read_text())
    cfg = {"scene": copy.deepcopy(raw["scene"])}
    cfg["scene"]["rod"]["youngs_modulus"] = f"{float(youngs_modulus)!r} Pa"
    cfg["scene"]["field"]["magnitude"] = f"{float(field_mT)!r} mT"
    cfg["scene"]["field"]["angle"] = f"{float(angle_deg)!r} deg"
    return cfg


def deflection(youngs_modulus: float, field_mT: float, angle_deg: float = 180.0, initial=None):
    """Forward ``solve`` of the scene: (max_s |y(s)|/L, tip y/L, result), or None when it fails
    or is not stable. ``initial``: a warm start (an ``EquilibriumResult``) to stay on its branch."""
    from actuator_design import load_scene, solve
    scene, options, _ = load_scene(scene_config(youngs_modulus, field_mT, angle_deg))
    r = solve(scene, options, initial=initial)
    if not (r.success and r.stable):
        return None
    y = r.evaluate(np.linspace(0.0, 1.0, 2001))["y"]
    return float(np.max(np.abs(y))), float(r.tip["y"]), r


def upward(youngs_modulus: float, field_mT: float, angle_deg: float, start):
    """The stable upward-buckled state (tip y > 0) of the scene, from ``start`` or from rest;
    None when the scene has none near there (the branch has folded away)."""
    for initial in (start, None):
        got = deflection(youngs_modulus, field_mT, angle_deg, initial)
        if got is not None and got[1] > 0.0:
            return got
    return None


def sensitivity_at_5mT(result) -> dict:
    """δ/L at 5 mT of the fitted model, the tilted fields and the ends of E's interval."""
    E = result.parameters["youngs_modulus"]["value"]
    lo, hi = result.parameters["youngs_modulus"]["ci"]
    base = upward(E, 5.0, 180.0, None)
    out = {"perfect": base[1], "E_low": upward(lo, 5.0, 180.0, base[2])[1],
           "E_high": upward(hi, 5.0, 180.0, base[2])[1], "towards": {}, "against": {}}
    for eps in IMPERFECTIONS_DEG:
        # φ = 180° − ε tilts the field so that the up-buckled branch is the favoured one
        t = upward(E, 5.0, 180.0 - eps, base[2])
        a = upward(E, 5.0, 180.0 + eps, base[2])
        out["towards"][eps] = None if t is None else t[1]
        out["against"][eps] = None if a is None else a[1]
    return out


def refit_without_5mT():
    """E (Pa) and its 95 % interval fitted without the 5 mT row."""
    from actuator_design.calibration import fit, parse_data, prepare_fit
    text = DATA.read_text().splitlines()
    kept = [ln for ln in text if not ln.replace(" ", "").startswith("5,")]
    import yaml
    ignore = yaml.safe_load(CONFIG.read_text())["study"]["ignore_columns"]
    data = parse_data("\n".join(kept), DATA.name + " (without 5 mT)", ignore_columns=ignore)
    res = fit(prepare_fit(CONFIG, data), interruptible=False)
    p = res.parameters["youngs_modulus"]
    return res, p["value"], p["ci"]


def figure(result, bc, path: Path) -> Path:
    """Measured δ/L (±0.01) and the fitted curve against B (mT), the buckling field marked."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    d = result.data
    B_data = d.columns["field"] * MU0 * 1e3
    delta = d.columns["tip_deflection"] / L
    fig, ax = plt.subplots(figsize=(6.0, 4.2))
    for g in result.curves["groups"]:
        ok = g["stable"]
        ax.plot(g["x"][ok] * MU0 * 1e3, g["y"]["tip_deflection"][ok] / L, "-", color="C0",
                label=f"model, E = {result.parameters['youngs_modulus']['value'] / 1e6:.3g} MPa")
    # the perfect rod below the data: straight until B_c, then δ/L ∝ √(B − B_c)
    E = result.parameters["youngs_modulus"]["value"]
    B_low = np.linspace(bc["value"] * 1.002, B_data.min(), 12)
    start, low = None, []
    for b in B_low[::-1]:
        got = upward(E, float(b), 180.0, start)
        low.append(np.nan if got is None else got[1])
        start = None if got is None else got[2]
    ax.plot(np.r_[0.0, bc["value"], B_low], np.r_[0.0, 0.0, low[::-1]], "-", color="C0", alpha=0.5)
    ax.errorbar(B_data, delta, yerr=SIGMA, fmt="o", color="k", capsize=3,
                label="Zhao et al. 2019 (digitised, ±0.01)")
    ax.axvline(bc["value"], color="C3", ls=":", lw=1,
               label=f"buckling field B_c = {bc['value']:.2f} mT")
    ax.set_xlabel("applied field B (mT), anti-parallel to the magnetisation")
    ax.set_ylabel("maximum deflection δ/L")
    ax.set_xlim(0, 1.05 * B_data.max())
    ax.set_ylim(0, 1)
    ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def _inside_repo(path: Path) -> bool:
    try:
        path.resolve().relative_to(ROOT)
        return True
    except ValueError:
        return False


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out_dir", nargs="?", help="directory for the figure (default: a new temp dir)")
    args = ap.parse_args(argv)
    out = Path(args.out_dir) if args.out_dir else Path(tempfile.mkdtemp(prefix="zhao2019_"))
    if _inside_repo(out):
        print(f"refusing to write into the repository ({out}); give a directory outside it",
              file=sys.stderr)
        return 2
    out.mkdir(parents=True, exist_ok=True)

    res = fitted()
    p = res.parameters["youngs_modulus"]
    rms = res.rms["tip_deflection"]  # mm, the unit of the data column
    gof = res.goodness_of_fit
    print(f"fit status       : {res.status} ({'success' if res.success else 'FAILED'})")
    print(f"E                = {p['value'] / 1e6:.4f} MPa, 95 % interval "
          f"[{p['ci'][0] / 1e6:.4f}, {p['ci'][1] / 1e6:.4f}] MPa")
    print(f"rms residual     = {rms:.4f} mm = {rms * 1e-3 / L:.4f} L  (data ±{SIGMA} L); "
          f"reduced chi-square {gof['chi2_reduced']:.3g} (dof {gof['dof']}, p = {gof['p_value']:.3g})")
    print("   B [mT]   δ/L measured   δ/L model   residual")
    for B, y, m in zip(res.data.columns["field"] * MU0 * 1e3, res.data.columns["tip_deflection"],
                       res.model[:, 0]):
        print(f"  {B:6.1f}      {y / L:.3f}        {m / L:.3f}     {(m - y) / L:+.3f}")
    bc = buckling_field_mT(res)
    print(f"buckling field   B_c = {bc['value']:.3f} mT [{bc['ci'][0]:.3f}, {bc['ci'][1]:.3f}] "
          "(h_r = pi^2/4, THEORY §9)")
    s = sensitivity_at_5mT(res)
    print("sensitivity at 5 mT (δ/L, forward solve):")
    print(f"  perfect rod, fitted E        : {s['perfect']:.3f}")
    print(f"  E at the interval's ends     : {s['E_low']:.3f} (E low), {s['E_high']:.3f} (E high)")
    fmt = lambda v: "no upward state" if v is None else f"{v:.3f}"  # noqa: E731
    for eps in IMPERFECTIONS_DEG:
        print(f"  field {eps:3.1f} deg off anti-parallel: {fmt(s['towards'][eps])} (tilted "
              f"towards the measured side), {fmt(s['against'][eps])} (against)")
    res6, E5, ci5 = refit_without_5mT()
    print(f"refit without 5 mT: E = {E5 / 1e6:.4f} MPa [{ci5[0] / 1e6:.4f}, {ci5[1] / 1e6:.4f}], "
          f"rms {res6.rms['tip_deflection'] * 1e-3 / L:.4f} L")
    path = figure(res, bc, out / "zhao2019_fit.png")
    print(f"figure           : {path}")
    return 0 if res.success else 3


if __name__ == "__main__":
    sys.exit(main())
