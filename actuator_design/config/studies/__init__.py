"""Every ``study:`` schema, in one place: a configuration's ``study: {type: ..., ...}`` section.

Modules (one job each; none is imported by this package's ``__init__``, so a command pays only for
the schema it reads):

validation  the strict base model, errors raised inside a schema, translation of a failure into a
            one-line ``study.<field>: ...`` :class:`~actuator_design.config.ConfigError`
commands    the analysis commands' studies (``equilibria``, ``path``, ``phase``, ``stiffness``) and
            the ``schedule`` command's keys
parameters  the studies that name a parameter of the lens (``continue``, ``critical``, ``map``)
sweep       ``type: sweep`` (grids of scene values, analyses, outputs, figures)
fit         ``type: fit`` (parameters to fit, bounds, uncertainties, goodness of fit)
"""
