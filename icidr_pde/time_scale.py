"""The fastest time scale of the shear cell's right-hand side, 1/rho(J), and the smallest step it sets.

Plain numpy, so that every engine computes it with this one function: the stiff solvers of
:mod:`icidr_pde.engines` (scipy, scikit-sundae, PETSc) and the compiled problems of the native engine
(:mod:`icidr_pde.native`, whose warm run imports neither scipy nor py-pde) on their compiled
right-hand side; below both, so that a compiled problem imports no engine.
"""

from __future__ import annotations

import numpy as np

__all__ = ["MIN_STEP_FRACTION", "fastest_time_scale"]

MIN_STEP_FRACTION = 1e-11  # of the fastest time scale: 9e-15 for mu(I), fd N = 201 (was 1e-14)


def fastest_time_scale(fun, t0: float, y0: np.ndarray, iterations: int = 20, *, norm=np.linalg.norm,
                       index=None) -> float:
    """1/rho(J) at (t0, y0): the inverse spectral radius of the Jacobian, estimated by power
    iteration on difference quotients J v (within 1 % of the largest |eigenvalue| for the
    shear cell). Measured: 1.5e-5 (iCIDR, fd N = 201), 8.8e-4 (mu(I), fd N = 201),
    4.5e-15 (iCIDR, phi0 = 0.816999), 1.1e-13 (iCIDR, H = 0.01, N = 47).

    Where y0 is one process's part of a distributed vector (PETSc's blocks), `index` is each of
    its entries' index in the whole vector and `norm` the whole vector's norm (the same on every
    process): the same iteration, the same number."""
    y0 = np.asarray(y0, dtype=float)
    f0 = fun(t0, y0)
    v = np.cos((np.arange(y0.size) if index is None else index) * 2.0) + 0.5  # a fixed start: reproducible
    v /= norm(v)
    e = 1e-7 * max(norm(y0), 1e-300)
    rho = 0.0
    for _ in range(iterations):
        jv = (fun(t0, y0 + e * v) - f0) / e
        rho = float(norm(jv))
        if not np.isfinite(rho) or rho == 0:
            break
        v = jv / rho
    return 1.0 / rho if np.isfinite(rho) and rho > 0 else 1.0
