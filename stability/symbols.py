"""Shared sympy symbols of the stability toolkit (one definition for every module).

The physical symbols (phi, the material parameters) are the simulator's, from
:mod:`icidr_pde.rheology.symbols`. Dimensional symbols d (grain diameter) and rho_*
(grain density) are kept so that the factor conventions of the printed formulas (e.g. the
d^2 of (A10)) are checked; numerical evaluation always uses d = rho_* = 1, the scalings (3.12).
"""

import sympy as sp

from icidr_pde.rheology.symbols import MATERIAL_SYMBOLS as _CORE_SYMBOLS
from icidr_pde.rheology.symbols import phi  # noqa: F401

uz, wz = sp.symbols("u_z w_z", real=True)       # base strain rates d_z u, d_z w
d, rho = sp.symbols("d rho_star", positive=True)
I = sp.Symbol("I", positive=True)               # inertial number (2.9)
p = sp.Symbol("p", positive=True)               # pressure as an independent variable (CIDR)
delta = sp.Symbol("delta", real=True)           # div u
Sn = sp.Symbol("S_n", positive=True)            # ||S|| > 0 as an independent variable
xi = sp.Symbol("xi", positive=True)             # wavenumber
lam = sp.Symbol("lambda")                       # growth rate
Lam = sp.Symbol("Lambda")                       # lambda / xi^2
w0 = sp.Symbol("w0", real=True)                 # base vertical velocity (convection)

# material parameters of (2.10)-(2.11), the default laws (other laws: their material's own symbols)
MATERIAL_SYMBOLS = {k: _CORE_SYMBOLS[k] for k in ("mu_s", "mu_d", "I0", "phi_c", "a")}
mu_s, mu_d, I0, phi_c, a = MATERIAL_SYMBOLS.values()

# generic material functions M(phi) = mu(Psi(phi)) and Psi(phi): identities proved
# with these hold for *any* positive M and Psi, not only for (2.10)-(2.13)
Mf = sp.Function("M", positive=True)
Psif = sp.Function("Psi", positive=True)
# their values at one point (Gamma involves no phi-derivative)
M, Psi = sp.symbols("M Psi", positive=True)
