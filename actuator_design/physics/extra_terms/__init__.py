"""Energy terms beyond the paper's, one module each (registered on import by
:func:`actuator_design.physics.registry.registered_terms`).

A term here is a plug-in term like a user's (:class:`~actuator_design.physics.terms.EnergyTerm`
registered with :func:`~actuator_design.physics.registration.register_term`): a scene lists it in
``extra_terms`` (YAML: ``terms: [{type: <name>, ...}]``; CLI: ``--set <parameter>=<value>``), and
solve, continuation, design, robust design, fit, studies and ``result.json`` treat it like any
other term.
"""
