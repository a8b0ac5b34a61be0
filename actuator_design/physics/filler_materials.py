"""Material presets for common magnetic fillers (THEORY §2, §9, §11).

Each preset gives the filler's intrinsic (particle) susceptibility, its saturation magnetisation
M_s and, for hard magnets, its remanent magnetisation M_r, all per unit volume of the *particle*
(SI: dimensionless and A/m). The composite's values follow with the volume fraction ν (THEORY §2:
χ̄ = ν χ, saturation ν M_s; §9: M_r,composite = ν M_r). The values are typical room-temperature
handbook values; a supplier's datasheet for the actual powder is better, and overrides them
(give ``chi_par``/``chi_perp``/``saturation_magnetization`` next to ``material``).

Sources
-------
* iron (carbonyl iron powder, ≥ 97 % Fe): μ0 M_s = 2.15 T, M_s = 1.71 MA/m — J. M. D. Coey,
  *Magnetism and Magnetic Materials*, Cambridge University Press (2010), table 8.1 (Fe);
  intrinsic susceptibility of soft iron ≫ 100 (taken as 1000: any value ≫ 1/N gives the
  shape-limited particle response 1/N, THEORY §2) — Jolly, Carlson & Muñoz, Smart Mater. Struct.
  5, 607 (1996), who model carbonyl-iron MR elastomers this way.
* magnetite (Fe3O4): M_s = 0.48 MA/m — Coey (2010), table 11.2; initial susceptibility of
  multidomain magnetite ≈ 3 (SI, volume) — Dunlop & Özdemir, *Rock Magnetism*, Cambridge (1997),
  §5.
* NdFeB (isotropic melt-spun powder, e.g. Magnequench MQFP-B, the filler of Kim et al., Nature 558,
  274 (2018)): remanence B_r ≈ 0.9 T, M_r ≈ 0.72 MA/m — Magnequench MQFP-B datasheet;
  μ0 M_s = 1.61 T, M_s = 1.28 MA/m (Nd2Fe14B) — Coey (2010), table 11.4. Susceptibility about the
  remanent state (recoil permeability ≈ 1.05–1.2): χ ≈ 0.1, small: the hard rod's coupling is the
  remanent torque of THEORY §9.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, Optional

__all__ = ["Material", "MATERIALS", "material"]


@dataclass(frozen=True)
class Material:
    """A magnetic filler (per unit volume of particle material).

    Attributes
    ----------
    name : str
    susceptibility : float
        Intrinsic (isotropic) susceptibility χ of the particle material, dimensionless.
    saturation_magnetization : float
        M_s, A/m.
    remanence : float or None
        M_r, A/m, for hard magnets (None for soft ones).
    source : str
        Where the values come from (see the module docstring).
    """

    name: str
    susceptibility: float
    saturation_magnetization: float
    remanence: Optional[float] = None
    source: str = ""


MATERIALS: Dict[str, Material] = {
    "carbonyl_iron": Material("carbonyl iron", 1000.0, 1.71e6, None,
                              "Coey 2010 table 8.1 (Fe); Jolly et al. 1996"),
    "magnetite": Material("magnetite", 3.0, 4.8e5, None,
                          "Coey 2010 table 11.2; Dunlop & Ozdemir 1997 §5"),
    "ndfeb": Material("NdFeB (MQFP-B)", 0.1, 1.28e6, 7.2e5,
                      "Magnequench MQFP-B datasheet; Coey 2010 table 11.4; Kim et al. 2018"),
}


def material(name: str) -> Material:
    """The preset ``name``; ValueError listing the presets otherwise."""
    try:
        return MATERIALS[name]
    except KeyError:
        raise ValueError(f"unknown material {name!r} (allowed: {', '.join(MATERIALS)})") from None
