"""``python -m actuator_design.cli``: the ``actuator-design`` command line."""
from .main import run

run()
