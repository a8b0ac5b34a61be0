"""Benchmark set and runners for speed against accuracy (issue 4).

``problems``  canonical scenes with references computed independently of the solvers under test;
``bvp``       the rod's Euler–Lagrange boundary-value problem in first-order form (numpy/scipy only):
              scipy ``solve_bvp`` as the peer and a multi-parameter shooting reference for
              position-dependent fields (dipole);
``runner``    methods, the timing protocol and the table.

The error–time (Pareto) figure is :mod:`actuator_design.viz.bench`'s.
"""
