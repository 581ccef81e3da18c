"""The rheology workbench's report: is a law well-posed, and what does it imply?

For a law of :mod:`icidr_pde.rheology` (a registered name, a law file, or an instance):

* **conditions (4.3)-(4.5)** of a CIDR law (Y, f) (:func:`check_conditions`), with the
  quantities of :mod:`stability.cidr` (one definition): first symbolically, with M, Psi,
  p, I positive symbols and the parameters symbolic (a proof for *every* material with
  M, Psi > 0); where sympy cannot decide, on the dense sample :func:`condition_sample`
  of the physical domain (p, I log-uniform, phi uniform in the law's range, the material's
  M(phi), Psi(phi)); a failing condition gets a counterexample state and the box of the
  sample where it fails. A law given directly as p and tau (mu(I),Phi(I)) has no (Y, f):
  its conditions are "not applicable" and only the symbol decides;
* **the symbol over a grid of states** (:func:`symbol_grid`): Lambda_pm of (A9) in 1-D
  (Gamma (A5) from the generated shear-cell kernel Jacobian, no derivative written by
  hand) and the 2-D plane-wave maximum over directions (Gamma(n) from the generated
  invariant Jacobian (d/d phi, div u, ||S||) through the closed form of
  :mod:`stability.plane`; by isotropy a state is (phi, div u/||S||, ||S||));
* **curves** (:func:`curves`): Y/p against I for several phi at p = 1 (fig 5 generalised)
  and the steady (div u = 0) mu(I), Phi(I) the law implies (at ||S|| = 1/2, gamma-dot = 1).

``well_posed`` is the verdict of the symbol on the grid (strictly negative Re Lambda_+ at
every state, 1-D, 2-D and 3-D: :mod:`stability.spatial`, waves in every direction of space with
the 3-D deviator; and p, c defined); for a CIDR law the report also says, separately
(``conditions_hold``), whether (4.3)-(4.5) hold, which by Barker et al. (2017) makes it
well-posed at *every* state: they are sufficient, not necessary, and a law failing them may
still have a negative symbol everywhere. :func:`check_summary` is the one line ``run`` prints
for a law file whose check fails.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["resolve_law", "check_conditions", "symbol_grid", "curves", "law_report", "write_report",
           "condition_sample", "law_list", "check_summary"]

#: the sample of (4.3)-(4.5) where sympy cannot decide (stated in every report): phi uniform in the
#: law's domain, plus `near_phi_c` points uniform in [phi_c - 0.03, phi_c + 0.015] (within the domain)
SAMPLE = {"p": (1e-4, 1e6, 31), "I": (1e-4, 10.0, 31), "phi": 25, "near_phi_c": (0.03, 0.015, 31)}


def _phi_points(rheology, n_uniform, near):
    """phi uniform inside the law's domain (ends excluded), plus points dense around phi_c where the
    domain reaches it (the jamming transition, where laws such as the blended one change character)."""
    lo, hi = law_domain(rheology)
    phis = np.linspace(lo, hi, n_uniform + 2)[1:-1]
    phi_c = dict(zip(rheology.material.parameter_names(), rheology.material.params)).get("phi_c")
    if phi_c is None or near is None:
        return phis, ""
    below, above, n = near
    a, b = max(lo, phi_c - below), min(hi, phi_c + above)
    extra = np.linspace(a, b, n + 2)[1:-1] if b > a else np.empty(0)
    extra = extra[(extra > lo) & (extra < hi)]
    text = f" + {extra.size} phi uniform in ({a:.4g}, {b:.4g}) around phi_c = {phi_c:g}" if extra.size else ""
    return np.unique(np.concatenate([phis, extra])), text


def resolve_law(law, material=None):
    """A Rheology instance from a registered name, a law file (``*.py``) or an instance/class."""
    from icidr_pde.rheology import Rheology, get_rheology
    from icidr_pde.rheology.law_files import is_file_law, load_law_file

    if isinstance(law, Rheology):
        return law
    if isinstance(law, type) and issubclass(law, Rheology):
        return law(material)
    if is_file_law(law):
        return load_law_file(law)(material)
    return get_rheology(law, material)


def law_domain(rheology):
    """The open phi interval a law is used on: its own (e.g. across phi_c) or the material's."""
    rng = getattr(rheology, "phi_domain", None)
    return tuple(rng()) if callable(rng) else tuple(rheology.material.phi_range)


def condition_sample(rheology):
    """(p, I, phi) arrays of the dense sample (see :data:`SAMPLE`) and its description."""
    lo, hi = law_domain(rheology)
    p_lo, p_hi, n_p = SAMPLE["p"]
    i_lo, i_hi, n_i = SAMPLE["I"]
    phis, near = _phi_points(rheology, SAMPLE["phi"], SAMPLE["near_phi_c"])
    P, I, F = np.meshgrid(np.logspace(math.log10(p_lo), math.log10(p_hi), n_p),
                          np.logspace(math.log10(i_lo), math.log10(i_hi), n_i), phis, indexing="ij")
    text = (f"{n_p} p log-uniform in [{p_lo:g}, {p_hi:g}] x {n_i} I log-uniform in [{i_lo:g}, {i_hi:g}] x "
            f"({SAMPLE['phi']} phi uniform in ({lo:g}, {hi:g}){near}; {phis.size} phi): {P.size} states")
    return P.ravel(), I.ravel(), F.ravel(), text


@dataclass
class Condition:
    """Status of one condition: 'holds', 'fails' or 'not applicable'."""

    status: str
    method: str | None
    counterexample: dict | None = None
    expression: str = ""
    region: dict | None = None
    sample: str | None = None

    def to_json(self) -> dict:
        out = {"status": self.status, "method": self.method, "counterexample": self.counterexample,
               "expression": self.expression}
        if self.region is not None:
            out["region"] = self.region
        if self.sample is not None:
            out["sample"] = self.sample
        return out


def _evaluate(rheology, expr, P, I, F):
    """`expr` in (p, I, phi, M, Psi, parameters) on the sample (M, Psi of the material)."""
    import sympy as sp

    from icidr_pde.rheology import symbols as s
    from icidr_pde.rheology.cidr import pressure_symbol

    mat = rheology.material
    prm = mat.values(symbolic=True)
    names = mat.parameter_names()
    f = sp.lambdify((pressure_symbol(), s.I, s.phi, s.M, s.Psi, *[prm[k] for k in names]), expr, modules="numpy")
    with np.errstate(all="ignore"):
        M, Psi = _material_functions(rheology, F)
        out = f(P, I, F, M, Psi, *mat.params)
    return np.broadcast_to(np.asarray(out, dtype=float), P.shape)


def _material_functions(rheology, phi):
    """M(phi), Psi(phi) of the material, continued beyond its range by the same formulas."""
    funcs = rheology.material._functions()
    return funcs.M(phi, rheology.material.params), funcs.Psi(phi, rheology.material.params)


def _state(P, I, F, i, value=None):
    out = {"p": float(P[i]), "I": float(I[i]), "phi": float(F[i])}
    if value is not None:
        out["value"] = float(value)
    return out


def _region(P, I, F, bad):
    return {"fraction_of_sample": float(bad.mean()),
            "p": [float(P[bad].min()), float(P[bad].max())],
            "I": [float(I[bad].min()), float(I[bad].max())],
            "phi": [float(F[bad].min()), float(F[bad].max())]}


def _simplified(expr):
    """sympy's simplify for small expressions; factor(together()) for large ones (bounded cost)."""
    import sympy as sp

    if sp.count_ops(expr) <= 150:
        return sp.simplify(expr)
    return sp.factor(sp.together(expr))


def _decide(rheology, expr, sign, name):
    """One condition: expr == 0 (sign 0), > 0 (sign +1) or < 0 (sign -1)."""
    import sympy as sp

    expr = _simplified(expr)
    text = sp.sstr(expr)
    symbolic = {0: expr == 0, 1: expr.is_positive, -1: expr.is_negative}[sign]
    if sign == 0 and symbolic is False:
        # a non-zero-looking expression may still vanish: decided only if sympy proves it has
        # a sign (e.g. -I*M/(2*Psi) with I, M, Psi > 0), else sampled
        symbolic = False if (expr.is_positive or expr.is_negative) else None
    P, I, F, sample = condition_sample(rheology)
    if symbolic is True:
        return Condition("holds", "symbolic", None, text)
    values = _evaluate(rheology, expr, P, I, F)
    if sign == 0 and symbolic is False:  # proved non-zero: every state is a counterexample
        bad = np.isfinite(values)
    elif sign == 0:
        scale = _evaluate(rheology, sp.Add(*[abs(t) for t in sp.Add.make_args(sp.expand(expr))]), P, I, F)
        bad = ~(np.abs(values) <= 1e-9 * np.maximum(scale, 1e-300))
    elif sign > 0:
        bad = ~(values > 0)
    else:
        bad = ~(values < 0)
    if sign == 0:
        bad &= np.isfinite(values)
    method = "symbolic" if symbolic is False else "sampled"
    if sign == 0 and symbolic is False and not np.any(bad):  # proved non-zero, not finite on the sample
        return Condition("fails", method, None, text, sample=sample)
    if not np.any(bad):
        return Condition("holds", method, None, text, sample=sample)
    i = int(np.argmax(bad))
    return Condition("fails", method, _state(P, I, F, i, values[i]), text, region=_region(P, I, F, bad),
                     sample=sample)


def check_conditions(rheology) -> dict:
    """{'(4.3)': Condition, '(4.4)': ..., '(4.5)': ...} for a CIDR law; 'not applicable' otherwise."""
    from icidr_pde.rheology.cidr import CIDRLaw

    from . import cidr

    if not isinstance(rheology, CIDRLaw):
        why = "law given directly as p and tau: (4.3)-(4.5) concern a yield function and a flow rule"
        return {k: Condition("not applicable", None, None, why) for k in ("(4.3)", "(4.4)", "(4.5)")}
    Y, f = rheology.symbolic_yield(symbolic_material=True)
    return {"(4.3)": _decide(rheology, cidr.condition_43(Y, f), 0, "(4.3)"),
            "(4.4)": _decide(rheology, cidr.condition_44(Y), 1, "(4.4)"),
            "(4.5)": _decide(rheology, cidr.condition_45(f), -1, "(4.5)")}


def check_positivity(rheology):
    """Y > 0 (a yield stress, and c = Y/||S|| > 0 in the alignment law) on the condition sample.

    Not one of (4.3)-(4.5), but the 2-D symbol has the part (c/2) I (:func:`plane_gamma`): where
    Y < 0 plane waves grow without bound although (4.3)-(4.5) hold. None for a direct law.
    """
    from icidr_pde.rheology.cidr import CIDRLaw

    if not isinstance(rheology, CIDRLaw):
        return None
    Y, _ = rheology.symbolic_yield(symbolic_material=True)
    return _decide(rheology, Y, 1, "Y > 0")


# --- the symbol over a grid of states -------------------------------------------------------

#: states of the symbol grid: phi uniform inside the domain; gamma-dot = 2||S||; div u/||S||
#: (laws whose domain reaches beyond phi_c get `near_phi_c` phi around phi_c too, as SAMPLE)
GRID = {"phi": 12, "rate": (1.0 / 30.0, 1.0), "ratio": np.linspace(-1.5, 1.5, 13), "angles": 36,
        "near_phi_c": (0.03, 0.015, 9)}


def _grid_states(rheology):
    lo, hi = law_domain(rheology)
    phis = np.linspace(lo, hi, GRID["phi"] + 2)[1:-1]
    if hi > dict(zip(rheology.material.parameter_names(), rheology.material.params)).get("phi_c", hi):
        phis, _ = _phi_points(rheology, GRID["phi"], GRID["near_phi_c"])   # laws that run across phi_c
    F, G, R = np.meshgrid(phis, np.asarray(GRID["rate"]), GRID["ratio"], indexing="ij")
    return F.ravel(), G.ravel(), R.ravel()


def _eig_minus_gamma(G):
    """Eigenvalues (Lambda_+, Lambda_-) of -Gamma for an array (..., 2, 2), Lambda_+ the larger real part."""
    tr = G[..., 0, 0] + G[..., 1, 1]
    det = G[..., 0, 0] * G[..., 1, 1] - G[..., 0, 1] * G[..., 1, 0]
    r = np.sqrt((tr * tr - 4 * det).astype(complex))
    a, b = (-tr + r) / 2, (-tr - r) / 2
    swap = a.real < b.real
    return np.where(swap, b, a), np.where(swap, a, b)


def one_d_gamma(rheology, phi, uz, wz):
    """Gamma (A5) at shear-cell states from the generated kernel Jacobian: b_ij = dF_i/d(u_z, w_z)_j / phi."""
    J = np.array(rheology.kernels().stress_jacobian_numpy(phi, uz, wz, rheology.material.params))
    J = np.broadcast_to(J, (9,) + np.shape(phi)).reshape(3, 3, *np.shape(phi))   # (p, txz, tzz) x (phi, uz, wz)
    G = np.empty(np.shape(phi) + (2, 2))
    G[..., 0, 0], G[..., 0, 1] = J[1, 1] / phi, J[1, 2] / phi
    G[..., 1, 0], G[..., 1, 1] = (J[2, 1] - J[0, 1]) / phi, (J[2, 2] - J[0, 2]) / phi
    return G


def plane_gamma(rheology, phi, div_u, norm_S, angles_deg):
    """Gamma(n) of the plane-wave analysis at states with S = ||S|| [[0, 1], [1, 0]] (isotropy), per angle.

    rho phi Gamma = (c/2) I - n (p_div n + p_s m/(2s))^T + m (c_div n + c_s m/(2s))^T, m = S n
    (:mod:`stability.plane`), with (p, c) and their derivatives from the generated invariant kernels.
    Returns an array (states, angles, 2, 2).
    """
    from icidr_pde.rheology import INVARIANTS

    k = rheology.kernels(INVARIANTS)
    prm = rheology.material.params
    _, c = k.stress_numpy(phi, div_u, norm_S, prm)
    J = np.array(k.stress_jacobian_numpy(phi, div_u, norm_S, prm)).reshape(2, 3, -1)
    p_d, p_s, c_d, c_s = J[0, 1], J[0, 2], J[1, 1], J[1, 2]
    th = np.deg2rad(np.asarray(angles_deg, float))
    n = np.stack([np.cos(th), np.sin(th)], -1)                         # (angles, 2)
    m = norm_S[:, None, None] * n[None, :, ::-1]                      # S n with S = s [[0,1],[1,0]]
    nn = np.broadcast_to(n[None], m.shape)
    s2 = 2 * norm_S[:, None, None]
    left_p = p_d[:, None, None] * nn + p_s[:, None, None] * m / s2
    left_c = c_d[:, None, None] * nn + c_s[:, None, None] * m / s2
    G = (c[:, None, None, None] / 2) * np.eye(2) - nn[..., :, None] * left_p[..., None, :] \
        + m[..., :, None] * left_c[..., None, :]
    return G / phi[:, None, None, None]


@dataclass
class SymbolGrid:
    """Lambda_pm over the grid of states, 1-D and 2-D."""

    phi: np.ndarray
    rate: np.ndarray
    ratio: np.ndarray
    lambda_plus_1d: np.ndarray
    lambda_minus_1d: np.ndarray
    lambda_max_2d: np.ndarray
    worst_angle_2d: np.ndarray
    scale: np.ndarray
    notes: list = field(default_factory=list)

    def ill_posed_1d(self):
        return ~(self.lambda_plus_1d.real < -1e-9 * self.scale)

    def ill_posed_2d(self):
        return ~(self.lambda_max_2d < -1e-9 * self.scale)

    def to_json(self) -> dict:
        def worst(values, bad):
            i = int(np.argmax(np.where(np.isfinite(values), values, np.inf)))
            return {"phi": float(self.phi[i]), "gamma_dot": float(self.rate[i]),
                    "div_u_over_norm_S": float(self.ratio[i]), "Lambda_plus": float(values[i]),
                    "ill_posed_states": int(bad.sum())}

        b1, b2 = self.ill_posed_1d(), self.ill_posed_2d()
        return {
            "grid": {"phi": sorted(set(map(float, self.phi))), "gamma_dot": sorted(set(map(float, self.rate))),
                     "div_u_over_norm_S": sorted(set(map(float, self.ratio))), "angles_deg": GRID["angles"],
                     "states": int(self.phi.size),
                     "note": "1-D: u_z, w_z with w_z = div u, ||S|| = gamma_dot/2; 2-D: S = ||S|| [[0,1],[1,0]], "
                             "n at every sampled angle"},
            "one_d": {"well_posed": bool(not b1.any()), "max_Lambda_plus": worst(self.lambda_plus_1d.real, b1),
                      "Lambda_plus": [float(v) for v in self.lambda_plus_1d.real],
                      "Lambda_minus": [float(v) for v in self.lambda_minus_1d.real]},
            "two_d": {"well_posed": bool(not b2.any()), "max_Lambda_plus": worst(self.lambda_max_2d, b2),
                      "Lambda_max": [float(v) for v in self.lambda_max_2d],
                      "worst_angle_deg": [float(v) for v in self.worst_angle_2d]},
            "notes": self.notes,
        }


def symbol_grid(rheology) -> SymbolGrid:
    """Lambda_pm (1-D) and max over directions (2-D) at every state of :data:`GRID`."""
    F, G, R = _grid_states(rheology)
    S = G / 2
    div = R * S
    # 1-D: div u = w_z and ||S||^2 = (u_z^2 + w_z^2)/4  ->  u_z = sqrt(4 S^2 - w_z^2) needs |div| <= 2 S
    wz = div
    uz = np.sqrt(np.maximum(4 * S**2 - wz**2, 0.0))
    notes = ["1-D states with |div u| > 2||S|| do not exist in the shear cell; there u_z = 0 (pure compression)"]
    with np.errstate(all="ignore"):
        G1 = one_d_gamma(rheology, F, uz, wz)
        lp, lm = _eig_minus_gamma(G1)
        angles = np.linspace(0.0, 180.0, GRID["angles"], endpoint=False)
        G2 = plane_gamma(rheology, F, div, S, angles)
        l2, _ = _eig_minus_gamma(G2)
    l2r = l2.real
    worst = np.nanargmax(np.where(np.isfinite(l2r), l2r, -np.inf), axis=1)
    scale = np.maximum(np.abs(G1).reshape(len(F), -1).max(1), np.abs(G2).reshape(len(F), -1).max(1))
    return SymbolGrid(F, G, R, lp, lm, l2r.max(axis=1), angles[worst], scale, notes)


# --- curves ------------------------------------------------------------------------------

def curves(rheology, phis=None) -> dict:
    """Y/p against I at p = 1 for several phi (fig 5 generalised), and the steady mu(I), Phi(I).

    Steady: div u = 0 with ||S|| = 1/2 (gamma-dot = 1); then I = 2||S||/sqrt(p) and
    mu = ||tau||/p = c ||S||/p from the law's own equation of state.
    """
    from icidr_pde.rheology import INVARIANTS
    from icidr_pde.rheology.cidr import CIDRLaw

    lo, hi = law_domain(rheology)
    phis = np.linspace(lo, hi, 7)[1:-1] if phis is None else np.asarray(phis, float)
    out = {"phi": [float(v) for v in phis]}
    if isinstance(rheology, CIDRLaw):
        import sympy as sp

        Y, _ = rheology.symbolic_yield(symbolic_material=True)
        I = np.logspace(-3, 0, 40)
        P, II, FF = np.meshgrid(np.ones(1), I, phis, indexing="ij")
        from icidr_pde.rheology.cidr import pressure_symbol

        ratio = _evaluate(rheology, _simplified(Y / pressure_symbol()), P.ravel(), II.ravel(), FF.ravel())
        out["Y_over_p"] = {"I": [float(v) for v in I], "p": 1.0,
                           "values": ratio.reshape(len(I), len(phis)).T.tolist()}
    phi_s = np.linspace(lo, hi, 41)[1:-1]
    S = np.full_like(phi_s, 0.5)
    with np.errstate(all="ignore"):
        p, c = rheology.kernels(INVARIANTS).stress_numpy(phi_s, 0.0 * phi_s, S, rheology.material.params)
    out["steady"] = {"phi": [float(v) for v in phi_s], "I": [float(v) for v in 2 * S / np.sqrt(p)],
                     "mu": [float(v) for v in c * S / p], "p": [float(v) for v in p], "gamma_dot": 1.0}
    return out


# --- the report --------------------------------------------------------------------------

def law_report(law, material=None, *, with_curves: bool = True, progress=None) -> dict:
    """The report of `law` as a JSON-ready dict (schema: docs/laws.md, 'Command line, Python, JSON');
    `progress(text)`, if given, is told each stage as it starts."""
    from icidr_pde.rheology.cidr import CIDRLaw, LawError

    def stage(text):
        if progress is not None:
            progress(text)

    rheology = resolve_law(law, material)
    stage("law check: p and c on the sample ...")
    defined = _definedness(rheology)
    stage("law check: conditions (4.3)-(4.5) ...")
    conditions = check_conditions(rheology)
    report = {"law": rheology.name, "label": rheology.label, "kind": getattr(rheology, "kind", "direct"),
              "material": rheology.material.to_dict(), "phi_domain": list(law_domain(rheology))}
    if isinstance(rheology, CIDRLaw):
        stage("law check: equation of state ...")
        rheology.verify_closed_form()
        report["equation_of_state"] = _eos_summary(rheology)
    stage("law check: the symbol over the grid of states ...")
    grid = symbol_grid(rheology)
    sym = grid.to_json()
    sym["three_d"] = _three_d(rheology)
    symbol_ok = sym["one_d"]["well_posed"] and sym["two_d"]["well_posed"]
    hold = all(c.status == "holds" for c in conditions.values())
    report["conditions"] = {k: c.to_json() for k, c in conditions.items()}
    positivity = check_positivity(rheology)
    report["positivity"] = None if positivity is None else positivity.to_json()
    report["conditions_hold"] = hold if isinstance(rheology, CIDRLaw) else None
    report["defined"] = defined
    # the verdict is the symbol's: (4.3)-(4.5) are sufficient, not necessary (a law may fail them
    # and still be well-posed); reported beside it as `conditions_hold`
    report["well_posed"] = bool(symbol_ok and defined["status"] == "holds")
    report["stability"] = sym
    report["well_posed"] = report["well_posed"] and sym["three_d"]["well_posed"]   # waves in every direction of space
    if isinstance(rheology, CIDRLaw) and hold and not symbol_ok:
        if positivity is not None and positivity.status == "fails":
            report["stability"]["notes"].append("(4.3)-(4.5) hold but Y < 0 on part of the sample (see "
                                                "'positivity'): there c = Y/||S|| < 0 and the 2-D symbol's (c/2) I "
                                                "part makes plane waves grow")
        else:
            report["stability"]["notes"].append("(4.3)-(4.5) hold but the symbol is not negative on the grid: "
                                                "inconsistent, please report")
    if with_curves:
        stage("law check: curves ...")
        report["curves"] = curves(rheology)
    report["runnable"] = not (isinstance(rheology, CIDRLaw) and report["equation_of_state"]["no_positive_root_at"]) \
        and all(f["what"] == "c < 0" for f in defined["failures"])
    del LawError
    return report


def _three_d(rheology) -> dict:
    """The symbol in 3-D over the grid's states and every deviator shape (:func:`stability.spatial.grid_symbol`)."""
    from .spatial import grid_symbol

    return grid_symbol(rheology, _grid_states(rheology))


def check_summary(rheology) -> str | None:
    """One line if the law fails its check ((4.3)-(4.5) for a CIDR law, the symbol on the grid
    of states), None if it passes: what ``run`` prints before running a law file."""
    from icidr_pde.rheology.cidr import CIDRLaw

    rheology = resolve_law(rheology)
    failed = [f"{k} fails ({c.method})" for k, c in check_conditions(rheology).items() if c.status == "fails"]
    grid = symbol_grid(rheology)
    bad = [(dim, int(b.sum())) for dim, b in (("1-D", grid.ill_posed_1d()), ("2-D", grid.ill_posed_2d())) if b.any()]
    if not failed and not bad:
        return None
    states = grid.phi.size
    symbol = ("the symbol is ILL-POSED at " + ", ".join(f"{n} of {states} states in {dim}" for dim, n in bad)
              if bad else f"the symbol is well-posed at the {states} sampled states (1-D and 2-D)")
    conditions = ""
    if isinstance(rheology, CIDRLaw):
        conditions = ("(4.3)-(4.5) (sufficient) " + ("hold" if not failed else "not shown: " + ", ".join(failed))
                      + "; ")
    return f"law {rheology.name}: {conditions}{symbol} (`icidr-pde law check` for the report)"


def _definedness(rheology) -> dict:
    """p, c finite and p, c >= 0 on the sample of :func:`~icidr_pde.rheology.cidr.sample_states`.

    A law whose p or c is not finite there is refused (LawError: there is nothing to analyse);
    p < 0 or c < 0 is reported with the first state where it happens (the law is then neither
    well-posed nor, for p < 0, runnable).
    """
    from icidr_pde.rheology.cidr import LawError, ill_defined

    failures = ill_defined(rheology)
    for what, state, value in failures:
        if "not finite" in what:
            raise LawError(rheology.name, f"{what} (value {value}): the law is ill-defined", state)
    return {"status": "fails" if failures else "holds", "method": "sampled",
            "failures": [{"what": what, "counterexample": state, "value": value} for what, state, value in failures]}


def _eos_summary(rheology) -> dict:
    import sympy as sp

    from icidr_pde.rheology import symbols as s

    q, c = rheology._derived()
    if rheology.is_implicit():
        from icidr_pde.rheology.implicit import MAX_ITER, TOL

        residual = type(q).residual
        return {"method": "scalar solve in the kernels (no closed form): bracketed Newton on the flow-rule "
                          f"residual F(q), q = sqrt(p), increasing in q where (4.5) holds; relative tolerance "
                          f"{TOL:.3g}, at most {MAX_ITER} iterations; derivatives by the implicit function theorem",
                "residual": sp.sstr(residual), "sqrt_p": "root q of F(q) = 0", "c": sp.sstr(c),
                "no_positive_root_at": rheology.admissibility()}
    return {"method": "closed form" + (" (given, checked against the derived root)"
                                       if rheology.closed_form(s.phi, s.div_u, s.norm_S, s.M, s.Psi,
                                                               rheology.material.values(True)) is not None
                                       else " (derived by sympy)"),
            "sqrt_p": sp.sstr(q), "c": sp.sstr(c),
            "no_positive_root_at": rheology.admissibility()}


def write_report(report: dict, path) -> None:
    """Write `report` as JSON atomically (never half-written)."""
    from icidr_pde.outputs import write_atomically  # noqa: PLC0415

    text = json.dumps(report, indent=2, default=_json_default)
    write_atomically(path, lambda fh: fh.write(text))


def _json_default(x):
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    raise TypeError(f"not JSON serialisable: {x!r}")


def law_list() -> list[dict]:
    """Registered laws: name, label, kind (CIDR (Y, f) or direct (p, tau))."""
    from icidr_pde.rheology import RHEOLOGIES

    return [{"name": n, "label": cls.label, "kind": getattr(cls, "kind", "direct"),
             "doc": (cls.__doc__ or "").strip().splitlines()[0] if cls.__doc__ else ""}
            for n, cls in sorted(RHEOLOGIES.items())]
