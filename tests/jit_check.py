"""Shared check of the slow JIT tests: a JIT-compiled kernel gives the CasADi VM's numbers."""
import numpy as np
import pytest

from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.solver import get_solver


def jit_matches_vm(scene):
    """Gradient and Hessian of the JIT kernel against the VM's at one point (degree 8, 1 element);
    skips when no compiler works. Returns the JIT solver."""
    vm = get_solver(scene, SolverOptions(elements=1, degree=8))
    jit = get_solver(scene, SolverOptions(elements=1, degree=8, jit=True))
    if not jit.jit_note.startswith("JIT-compiled"):
        pytest.skip(jit.jit_note)
    P = vm.parameter_vector(scene)
    z = 0.2 * vm.transcription.nodes
    for s in (vm, jit):
        s.kernel.set_params(P)
        s.kernel.evaluate(z[1:])
    np.testing.assert_allclose(jit.kernel.g, vm.kernel.g, rtol=1e-13, atol=1e-14)
    np.testing.assert_allclose(jit.kernel.hnz, vm.kernel.hnz, rtol=1e-13, atol=1e-13)
    return jit
