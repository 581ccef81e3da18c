"""Section 4: conditions (4.3)-(4.5), reconstructed (4.6), derivation of (4.8), (4.9)-(4.14)."""

import sympy as sp

from stability import cidr
from stability.symbols import I, Mf, Psif, p, phi

M, Psi = Mf(phi), Psif(phi)


def test_conditions_on_a_hand_made_pair():
    """Generic operators on Y = p^2 I^3, f = p I, against hand differentiation."""
    Y = p**2 * I**3
    f = p * I
    assert sp.simplify(cidr.condition_43(Y, f) - (2 * p * I**3 - I / (2 * p) * 3 * p**2 * I**2 - 2 * p * I)) == 0
    assert cidr.condition_44(Y) == 3 * p**2 * I**2
    assert sp.simplify(cidr.condition_45(f) - (I - I / (2 * p) * p)) == 0


def test_rate_independent_yield_violates_44(checks_by_eq):
    assert cidr.condition_44(cidr.yield_rate_independent()) == 0
    assert checks_by_eq["(4.4) Y = mu p"][0].status == "exact"


def test_dilatancy_48_is_derived_not_typed():
    f = cidr.dilatancy_icidr()
    # independent truth: (4.8) as printed in the paper
    assert sp.simplify(f - M / 4 * (I / Psi - Psi / I)) == 0
    # it solves (4.3) and vanishes on the steady isochoric state (4.6)
    assert sp.simplify(cidr.condition_43(cidr.yield_icidr(), f)) == 0
    assert sp.simplify(f.subs(I, Psi)) == 0


def test_46_reconstruction_recovers_mu_phi():
    Y, f = cidr.yield_icidr(), cidr.dilatancy_icidr()
    rY, rf = cidr.steady_isochoric_relations(Y, f)
    assert rY == 0 and rf == 0
    assert sp.solve(sp.Eq(f, 0), I) == [Psi]     # div u = 0 <=> I = Psi(phi) <=> phi = Phi(I)


def test_inequalities_44_45_signs():
    assert sp.simplify(cidr.condition_44(cidr.yield_icidr())).is_positive
    assert sp.simplify(cidr.condition_45(cidr.dilatancy_icidr())).is_negative


def test_section4_all_hold(all_checks):
    sec4 = [c for c in all_checks if c.section == cidr.SECTION]
    assert len(sec4) >= 14
    assert all(c.status == "exact" for c in sec4), [(c.equation, c.status) for c in sec4 if c.status != "exact"]
    eqs = {c.equation for c in sec4}
    for e in ("(4.6)", "(4.7)", "(4.8)", "(4.9)", "(4.10)", "(4.11)", "(4.12)", "(4.12) well-defined", "(4.13)",
              "(4.14)", "(4.4)", "(4.5)"):
        assert e in eqs
