"""The sympy symbols every law is written in (one definition for the simulator and ``stability``).

* ``phi`` (solids volume fraction), ``div_u`` (div u), ``norm_S`` (||S|| of the deviatoric
  strain rate (2.5), ||T|| = sqrt(tr(T^2)/2)), ``I`` (inertial number (2.9));
* ``M`` and ``Psi``: placeholders for M(phi) = mu(Psi(phi)) and Psi(phi) (A11a), (2.13),
  used by laws written in terms of them (:meth:`Rheology.law`);
* :data:`MATERIAL_SYMBOLS`: one positive symbol per material parameter name.
"""

import sympy as sp

phi = sp.Symbol("phi", positive=True)
div_u = sp.Symbol("div_u", real=True)
norm_S = sp.Symbol("norm_S", nonnegative=True)
I = sp.Symbol("I", positive=True)  # noqa: E741
M = sp.Symbol("M", positive=True)
Psi = sp.Symbol("Psi", positive=True)

#: parameter name -> positive sympy symbol (names as the Material attributes)
MATERIAL_SYMBOLS = {
    "mu_s": sp.Symbol("mu_s", positive=True),
    "mu_d": sp.Symbol("mu_d", positive=True),
    "I0": sp.Symbol("I_0", positive=True),
    "phi_c": sp.Symbol("phi_c", positive=True),
    "a": sp.Symbol("a", positive=True),
    "phi_min": sp.Symbol("phi_min", positive=True),
    "I_star": sp.Symbol("I_star", positive=True),
}


def material_symbol(name: str) -> sp.Symbol:
    """The symbol of parameter `name` (created on first use for laws defined later)."""
    if name not in MATERIAL_SYMBOLS:
        MATERIAL_SYMBOLS[name] = sp.Symbol(name, positive=True)
    return MATERIAL_SYMBOLS[name]
