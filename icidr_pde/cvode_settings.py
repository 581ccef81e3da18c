"""The settings of CVODE that both CVODE engines share: scikit-sundae's
(:mod:`icidr_pde.engines.sundae`) and the native one on the compiled problems of
:mod:`icidr_pde.native`. Below both, so that a compiled problem imports no engine; numpy-free.
"""

__all__ = ["DENSE_LU_DELTA_GAMMA", "KRYLOV_EPS_LIN", "KRYLOV_DIM", "BDF_MAX_ORDER", "A_STABLE_ORDER"]

#: the highest order of CVODE's BDF (and of scipy's); orders 3-5 are A(alpha)-stable only, with
#: alpha = 86.0, 73.4, 51.8 degrees: eigenvalues closer to the imaginary axis than that are amplified
#: at some steps (central advection: h omega ~ 1-2.5 for BDF5; docs/sim2d.md, "Time integration")
BDF_MAX_ORDER = 5
#: the highest A-stable BDF order (Dahlquist's second barrier): no mode that the continuum damps is
#: amplified at any step
A_STABLE_ORDER = 2

#: refactor CVODE's dense Newton matrix when gamma = h/l0 changed by more than this (SUNDIALS: 0.3).
#: Measured, mu(I) shear t* and iCIDR sine, Chebyshev N = 201: 138 -> 100 and 130 -> 97 LU
#: decompositions, t* error against the converged t* 3.5e-5 -> 9.9e-6, max|w| error 6.4e-5 -> 5.1e-5
#: (0.6: 160 and 113 LUs; 1.5: 138 and 109)
DENSE_LU_DELTA_GAMMA = 1.0

#: CVODE's Krylov tolerance factor. SUNDIALS' 0.05 is too loose for an ill-posed law: the inexact
#: Newton solves delay the grid-scale growth (mu(I) bump2d 128^2: t* 0.11844; eps_lin 5e-4: 0.11709,
#: 5e-5: 0.11700, 5e-6: 0.11697; docs/scaling.md, benchmarks/tstar2d_solvers.py). Here (numpy only)
#: for both CVODE engines: scikit-sundae's (:mod:`icidr_pde.engines.sundae`) and the native one (:mod:`icidr_pde.cells.plane2d.native`)
KRYLOV_EPS_LIN = 5e-5
#: the Krylov subspace dimension of CVODE's GMRES on the 2-D cell (both CVODE engines)
KRYLOV_DIM = 20
