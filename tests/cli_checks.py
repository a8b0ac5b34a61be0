"""Shared assertion of the bad-input contract (README: one line naming the field, exit 2, nothing
written) for the CLI tests."""


def assert_rejected(result, tmp_path, *names, absent=()):
    """Exit 2, nothing on stdout, one line on stderr naming every one of ``names`` (and none of
    ``absent``), no ``tmp_path / "out"``; returns the line."""
    code, out, err = result
    assert code == 2, err
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("actuator-design: error: ") and "Traceback" not in err
    for name in names:
        assert name in lines[0], lines[0]
    for name in absent:
        assert name not in lines[0], lines[0]
    assert not (tmp_path / "out").exists()
    return lines[0]
