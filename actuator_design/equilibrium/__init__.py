"""One equilibrium: the solve pipeline (mesh, start from rest, solve, accept), its solver, acceptance, accuracy and result."""
