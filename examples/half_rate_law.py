"""A user-defined CIDR law: half of iCIDR's rate dependence, Y = M p (k I/Psi + 1 - k).

A Python law file is a program: `law check` and `run --rheology` run it. The same law as data
(formulas, nothing run) is half_rate_law.toml; see docs/security.md.
"""
name = "half-rate"
k = 0.5   # k = 1 is iCIDR (4.7); k = 0 the rate-independent Y = M p that violates (4.4)


def yield_function(p, I, phi, M, Psi, prm):
    return M * p * (k * I / Psi + 1 - k)


def dilatancy_function(p, I, phi, M, Psi, prm):   # from (4.3) with f = 0 at I = Psi (4.6)
    return M * (k * I / (4 * Psi) + 1 - k - Psi * (1 - 3 * k / 4) / I)
