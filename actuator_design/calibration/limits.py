"""The size limits of a fit and its plausibility bounds, in one place (README, ``fit --help``).

(The ``study:`` section of a fit is validated by :class:`actuator_design.config.studies.fit.FitSpec`.)

=========================  ===========  =======================================================
limit                      value        why
=========================  ===========  =======================================================
:data:`MAX_DATA_BYTES`     16 MiB       a data file larger than this is refused before reading
                                        (≈ 100 000 rows of five columns written in full)
:data:`MAX_DATA_ROWS`      100 000      data rows (after comments and blank lines)
:data:`MAX_CONDITIONS`     5 000        distinct measured conditions (field, field angle,
                                        loads): one forward solve each per model evaluation,
                                        ≈ 0.3 ms each, tens of evaluations per fit — about a
                                        minute on one core at the limit; average repeats or
                                        thin the data to fit more
=========================  ===========  =======================================================

Only regular files are read (a FIFO, a device such as ``/dev/zero`` or a directory is refused).

Goodness of fit: with every measured column's uncertainty σ given (``study.uncertainty``), the
weighted residuals r_i/σ of a model that explains the data are standard normal, so
χ² = Σ (r_i/σ)² follows the χ² distribution with m − k degrees of freedom (m residuals, k fitted
parameters). A fit whose χ² exceeds that distribution's upper ``study.min_p_value`` quantile
(:data:`~actuator_design.config.studies.fit.DEFAULT_MIN_P_VALUE`: an honest fit fails 1 time in
1000) does not explain its data.
"""
from __future__ import annotations

import math

__all__ = ["MAX_DATA_BYTES", "MAX_DATA_ROWS", "MAX_CONDITIONS",
           "PLAUSIBLE_LAYER", "PLAUSIBLE_H", "PLAUSIBLE_LOAD", "PLAUSIBLE_TIP_DISTANCE", "PLAUSIBLE_ANGLE"]

MAX_DATA_BYTES = 16 * 2**20
MAX_DATA_ROWS = 100_000
MAX_CONDITIONS = 5_000

#: Plausible magnitudes (:mod:`.plausibility`) at the initial parameters: beyond them the rod is
#: aligned with the field but for a boundary layer of this fraction of its length (each field group
#: declares how its layer narrows, ``Parameter.layer_power``: h ~ l/layer for the induced torque,
#: √h_r for the remanent one, THEORY §5, §9) …
PLAUSIBLE_LAYER = 0.01
#: (the field group h's largest plausible value, its layer ~1/h)
PLAUSIBLE_H = 1.0 / PLAUSIBLE_LAYER
#: … a dead load is 40 times the Euler buckling load (p = π²/4) …
PLAUSIBLE_LOAD = 100.0
#: … the tip lies farther from the clamp than the rod is long (in rod lengths, with room for noise)
PLAUSIBLE_TIP_DISTANCE = 1.5
#: … or an angle exceeds two turns (rad), e.g. degrees written with the unit [rad].
PLAUSIBLE_ANGLE = 4.0 * math.pi
