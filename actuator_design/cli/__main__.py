"""``python -m actuator_design.cli``: the ``actuator-design`` command line."""
from actuator_design.cli.main import run

run()
