"""``python -m actuator_design.cli``: the ``actuator-design`` command line."""
import sys

from .main import main

sys.exit(main())
