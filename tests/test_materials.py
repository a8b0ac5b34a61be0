"""The body's shape anisotropy (THEORY §10), saturation (§11), presets and the physical hard-magnetic
group (§9), each against its closed form or an independent computation."""
import json
import math
import warnings

import numpy as np
import pytest

from actuator_design.config import ConfigError, load_config
from actuator_design.model.units import MU0
from actuator_design.physics.magnetic_composite import (MATERIALS, ModelAssumptionWarning,
                                                        body_susceptibility, composite_tensor,
                                                        particle_susceptibilities,
                                                        transverse_demagnetizing_factor)

ROD = {"length": "30 mm", "width": "10 mm", "thickness": "1 mm", "youngs_modulus": "1 MPa"}


def physical(magnetics, field="20 mT", angle="90 deg", **extra):
    scene = {"type": "physical", "rod": dict(ROD), "magnetics": magnetics,
             "field": {"type": "uniform", "magnitude": field, "angle": angle}, **extra}
    return {"scene": scene}


@pytest.mark.parametrize("c, n_t", [(0.3, 0.8), (3.0, 10 / 11), (1e-3, 0.5), (50.0, 0.99)])
def test_isotropic_composite_gives_the_closed_form(c, n_t):
    """χ_c = c I: χ̄ = c² N_t/(1 + N_t c) along the tangent, χ̂ = c/(1 + N_t c) (THEORY §10)."""
    b = body_susceptibility(c * np.eye(2), 0.7, n_t)
    assert b.chi_bar == pytest.approx(c * c * n_t / (1 + n_t * c), rel=1e-12)
    assert b.chi_hat == pytest.approx(c / (1 + n_t * c), rel=1e-12)
    assert b.fibre_angle == pytest.approx(0.0, abs=1e-12)


def test_body_tensor_is_the_inverse_of_compliances():
    """Second method: χ_eff = (χ_c⁻¹ + N)⁻¹ for an invertible χ_c; and rotating the fibres by α
    rotates nothing when N = 0 (the eigenvector is the fibre)."""
    chi_c = composite_tensor(10.0, 4.0, 3.0, 0.1)
    alpha, n_t = 0.4, 0.7
    rot = np.array([[math.cos(alpha), -math.sin(alpha)], [math.sin(alpha), math.cos(alpha)]])
    ref = np.linalg.inv(np.linalg.inv(rot @ chi_c @ rot.T) + np.diag([0.0, n_t]))
    b = body_susceptibility(chi_c, alpha, n_t)
    np.testing.assert_allclose(b.tensor, ref, rtol=1e-12)
    lam = np.linalg.eigvalsh(ref)
    assert b.chi_bar == pytest.approx(lam[1] - lam[0], rel=1e-12)
    free = body_susceptibility(chi_c, alpha, 0.0)
    assert free.fibre_angle == pytest.approx(alpha, abs=1e-12)
    chi, chi_t = particle_susceptibilities(10.0, 4.0, 3.0)
    assert free.chi_bar == pytest.approx(0.1 * chi, rel=1e-12)


def test_rectangle_demagnetizing_factor():
    assert transverse_demagnetizing_factor(10e-3, 1e-3) == pytest.approx(10 / 11, rel=1e-15)
    assert transverse_demagnetizing_factor(1.0, 1.0) == 0.5  # square: the circular cylinder's 1/2


def _h(chi_bar, field_A_per_m):
    area, length = 10e-3 * 1e-3, 30e-3
    b0 = 1e6 * 10e-3 * 1e-9 / 12
    return math.sqrt(MU0 * chi_bar * field_A_per_m**2 * area * length**2 / (2 * b0))


def test_a_strip_of_iron_spheres_bends_by_its_own_shape_anisotropy():
    """The issue's new user: spherical carbonyl iron in a strip. Particle-only χ̄ = 0 (THEORY §2);
    with the body's demagnetisation h follows §10's closed form with c = ν/(1/χ + 1/3)."""
    mag = {"particles": {"material": "carbonyl_iron", "volume_fraction": 0.1}}
    scene = load_config(physical(mag)).to_scene()
    c = 0.1 / (1 / MATERIALS["carbonyl_iron"].susceptibility + 1 / 3)
    n_t = 10 / 11
    H = 20e-3 / MU0
    assert scene.h == pytest.approx(_h(c * c * n_t / (1 + n_t * c), H), rel=1e-12)
    assert scene.fibres.value == pytest.approx(0.0, abs=1e-12)
    off = load_config(physical({**mag, "body_demagnetization": False})).to_scene()
    assert off.h == 0.0
    user = load_config(physical({**mag, "demagnetizing_factor": 0.5})).to_scene()
    assert user.h == pytest.approx(_h(c * c * 0.5 / (1 + 0.5 * c), H), rel=1e-12)


def test_hard_magnetic_physical_group():
    """h_r = μ0 M_r H A ℓ² / B0 (THEORY §9); remanent_flux_density = μ0 M_r."""
    H = 20e-3 / MU0
    area, length, b0 = 1e-5, 30e-3, 1e6 * 10e-3 * 1e-9 / 12
    expected = MU0 * 50e3 * H * area * length**2 / b0
    a = load_config(physical({"remanence": "50 kA/m"}, magnetization="90 deg")).to_scene()
    b = load_config(physical({"remanent_flux_density": f"{MU0 * 50e3!r} T"})).to_scene()
    c = load_config(physical({"remanent_flux_density": MU0 * 50e3})).to_scene()
    for sc in (a, b, c):
        assert sc.h_r == pytest.approx(expected, rel=1e-12) and sc.h == 0.0
    assert a.magnetization.value == pytest.approx(math.pi / 2)
    assert b.magnetization.value == 0.0


@pytest.mark.parametrize("mag, extra, field", [
    ({"remanent_flux_density": "50 kA/m"}, {}, "scene.magnetics.remanent_flux_density"),
    ({"remanence": "50 kA/m", "remanent_flux_density": "0.1 T"}, {}, "scene.magnetics.remanent_flux_density"),
    ({"chi_bar": 0.1}, {"magnetization": 0.3}, "scene.magnetization"),
    ({"particles": {"material": "unobtainium", "volume_fraction": 0.1}}, {}, "scene.magnetics.particles.material"),
    ({"particles": {"volume_fraction": 0.1}}, {}, "scene.magnetics.particles.chi_par"),
    ({"chi_bar": 0.1, "demagnetizing_factor": 1.5}, {}, "scene.magnetics.demagnetizing_factor"),
])
def test_bad_magnetics_name_the_field(mag, extra, field):
    with pytest.raises(ConfigError) as err:
        load_config(physical(mag, **extra))
    assert str(err.value).startswith(field), str(err.value)


def test_saturation_warning_gives_both_numbers():
    """Magnetite at 20 % in 0.5 T: |χ_eff H| ≈ 0.27 · 398 kA/m > ν M_s = 96 kA/m."""
    mag = {"particles": {"material": "magnetite", "volume_fraction": 0.2, "axis_ratio": 3}}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        load_config(physical(mag, field="0.5 T")).to_scene()
    msgs = [str(w.message) for w in caught if issubclass(w.category, ModelAssumptionWarning)
            and "saturation" in str(w.message)]
    assert len(msgs) == 1
    assert "96000 A/m" in msgs[0] or "9.6e+04 A/m" in msgs[0]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        load_config(physical(mag, field="1 mT")).to_scene()
    assert not [w for w in caught if "saturation" in str(w.message)]


def test_validate_reports_particle_only_and_effective_values_and_explains_zero(tmp_path, capsys):
    import yaml

    from actuator_design.cli.main import main

    mag = {"particles": {"material": "carbonyl_iron", "volume_fraction": 0.1}}
    on, off = tmp_path / "on.yaml", tmp_path / "off.yaml"
    on.write_text(yaml.safe_dump(physical(mag)))
    off.write_text(yaml.safe_dump(physical({**mag, "body_demagnetization": False})))
    assert main(["validate", "--json", str(on)]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["magnetics"]["particle_chi_bar"] == 0.0 and d["magnetics"]["chi_bar"] > 0
    assert d["magnetics"]["demagnetizing_factor"] == pytest.approx(10 / 11)
    assert main(["validate", str(off)]) == 0
    out = capsys.readouterr().out
    assert "valid       : yes, but the field exerts no force or torque on the rod" in out
    assert "isotropic particles" in out


def test_validate_json_reports_h_r(tmp_path, capsys):
    from actuator_design.cli.main import main

    cfg = tmp_path / "hr.yaml"
    cfg.write_text("scene: {type: dimensionless, h_r: 2.5, phi: 180 deg, magnetization: 10 deg}\n")
    assert main(["validate", "--json", str(cfg)]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["groups"]["h_r"] == 2.5 and "hard_magnetic" in d["terms"]
    assert d["magnetization"]["value"] == pytest.approx(math.radians(10))
