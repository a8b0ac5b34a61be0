"""Warnings reach the user as one line each: ``actuator-design: warning: <message>`` (issue 21 item 4).

The model-assumption checks of a physical scene (THEORY §11: a dense filler, a field above
saturation) are issued with :func:`warnings.warn`; the command line must print them without a
file path or source line, and each distinct message once.
"""
import warnings

from actuator_design.cli.main import main

DENSE = """\
name: dense strip
scene:
  type: physical
  rod: {length: 30 mm, width: 10 mm, thickness: 1 mm, youngs_modulus: 1 MPa}
  magnetics:
    particles: {material: carbonyl_iron, axis_ratio: 1, volume_fraction: 0.3}
  field: {type: uniform, magnitude: 900 mT, angle: 60 deg}
"""


def test_model_warnings_are_one_line_each(tmp_path, capsys):
    cfg = tmp_path / "dense.yaml"
    cfg.write_text(DENSE)
    assert main(["validate", str(cfg)]) == 0
    err = capsys.readouterr().err.splitlines()
    lines = [line for line in err if "warning" in line.lower()]
    assert any("dilute limit" in line for line in lines)
    assert any("saturation" in line for line in lines)
    for line in lines:
        assert line.startswith("actuator-design: warning: "), line
        assert ".py:" not in line and "Warning:" not in line
    assert len(lines) == len(set(lines))  # each once


def test_repeated_warning_printed_once(capsys):
    from actuator_design.cli import main as cli_main

    show_before = warnings.showwarning
    with warnings.catch_warnings():
        warnings.simplefilter("always")  # defeat the per-location registry: dedup must be ours
        warnings.showwarning = cli_main._one_line_warning(set())
        for _ in range(3):
            warnings.warn("the  same\nnote", UserWarning)
    assert warnings.showwarning is show_before
    err = capsys.readouterr().err.splitlines()
    assert err == ["actuator-design: warning: the same note"]  # whitespace folded, once
