"""Directional well-posedness of the 2-D equations: plane waves at an angle theta.

The 2-D equations (2.1)-(2.2) (with the corrected index form of (2.2)),
``phi_t + u.grad phi + phi div u = 0``, ``rho_* phi (u_t + u.grad u) = div sigma``,
are linearised about a uniform state phi0 with a constant velocity gradient
``L = grad u0`` (``L[i, j] = d_j u_i``; coordinates (x, z), so
``L = [[u_x, u_z], [w_x, w_z]]``), and the coefficients are frozen, as appendix A does
in 1-D.  Keeping the highest derivatives of each equation (convection by u0 only adds
an imaginary shift, (A4)), the principal part is

    phi_t = -phi0 d_k u_k,
    u_i,t = a_ij d_j phi + B_ijkl d_j d_l u_k,

    a_ij   = (d sigma_ij / d phi)    / (rho_* phi0),
    B_ijkl = (d sigma_ij / d L_kl)   / (rho_* phi0),

derived here by differentiating the 2-D stress tensor ``sigma = -p I + c S`` of
:func:`stress_tensor` (no coefficient is typed in).  A plane wave
``exp(i xi n.x + lambda t)``, ``n = (cos theta, sin theta)``, gives the 3x3 symbol

    A(xi, n) = [[0, -i xi phi0 n^T], [i xi alpha(n), -xi^2 Gamma(n)]],
    Gamma_ik(n) = B_ijkl n_j n_l,   alpha_i(n) = a_ij n_j,

the acoustic tensor of the linearised stress.  At theta = 90 deg (n = e_z) Gamma is
exactly (A5) and alpha = (a1, a2) of (A2); the large-xi balance is (A8) with Gamma(n),
so ``Lambda_max(theta) = max Re eig(-Gamma(n))`` and the bounded third root tends to
``phi0 n.Gamma(n)^-1 alpha(n)`` (the 2-D form of -C/B).

Closed forms (proved in :func:`checks`; m = S n, s = ||S||, delta = div u):

* any law on invariants, p(phi, delta, s), c(phi, delta, s) ((2.6) alignment):
  ``rho phi Gamma = (c/2) I - n (p_delta n + p_s m/(2s))^T + m (c_delta n + c_s m/(2s))^T``,
  ``rho phi alpha = -p_phi n + c_phi m``;
* mu(I),Phi(I) ((2.14), (2.7)): eig(-Gamma) = (4 d^2 s/(phi Psi^2)) {cos 2(theta-beta) - M, -M/2},
  beta the principal stretching direction of S; ill-posed iff cos 2(theta - beta) > M;
* iCIDR ((4.12), (4.14)): ``Gamma = K/(rho phi) [(q/2) I + (2/R) w w^T]`` with
  K = 4 rho d^2/Psi^2, R = sqrt(delta^2 + M^2 s^2), q = R - delta, w = (q/M) n - (M/2) m:
  symmetric, positive definite whenever q > 0 (s > 0 or delta < 0), and
  Lambda_max(theta) = -K q/(2 rho phi) = -2 d^2 (R - delta)/(phi Psi^2) for every theta.

The law enters through one object with ``symbolic_stress(phi, div_u, norm_S) -> (p, c)``
(the interface of the core's rheology registry); :func:`toolkit_law` takes a registered
rheology ('mui', 'icidr', or any other) from its one definition in :mod:`icidr_pde.rheology`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Callable

import sympy as sp

from icidr_pde.rheology import Rheology, get_rheology

from .checks import EXACT, FAILS, Check, exact_zero
from .symbols import M, Mf, Psi, Psif, d, delta, phi, rho, uz, wz

SECTION = "2-D plane waves"

ux, wx = sp.symbols("u_x w_x", real=True)
theta = sp.Symbol("theta", real=True)
# the base velocity gradient L[i, j] = d_j u_i (rows u, w; columns x, z)
VELOCITY_GRADIENT = sp.Matrix([[ux, uz], [wx, wz]])


# --- the law on invariants -------------------------------------------------------------

@dataclass(frozen=True)
class InvariantLaw:
    """A rheology as (p, c) on invariants: sigma = -p I + c S ((2.3), alignment (2.6)).

    `stress(phi, div_u, norm_S)` returns sympy expressions (p, c); `name` labels output.
    """

    name: str
    stress: Callable

    def symbolic_stress(self, phi_, div_u, norm_S):
        """(p, c) as sympy expressions of the given symbols/expressions."""
        return self.stress(phi_, div_u, norm_S)


def toolkit_law(name, M_=None, Psi_=None, material=None) -> InvariantLaw:
    """A rheology of the simulator's registry (:func:`icidr_pde.rheology.get_rheology`) as an :class:`InvariantLaw`.

    The one definition, :meth:`icidr_pde.rheology.Rheology.law` ((2.14)/(2.6)-(2.7) for 'mui',
    (4.12)/(4.14) for 'icidr'), with its material parameters as symbols and made dimensional
    (p and c times rho_* d^2, the scalings (3.12)).  M_, Psi_ default to the generic functions
    M(phi), Psi(phi) of :mod:`stability.symbols`; pass plain symbols for values at one state
    (Gamma needs no phi-derivative).  `name` may also be a Rheology instance.
    """
    M_ = Mf(phi) if M_ is None else M_
    Psi_ = Psif(phi) if Psi_ is None else Psi_
    r = get_rheology(name, material)
    prm = r.material.values(symbolic=True)

    def law(phi_, div_u, norm_S):
        p, c = r.law(phi_, div_u, norm_S, M_, Psi_, prm)
        return rho * d**2 * p, rho * d**2 * c

    return InvariantLaw(r.name or type(r).__name__, law)


def resolve_law(law, M_=None, Psi_=None, material=None):
    """A registered name ('mui', 'icidr', ...) or Rheology instance of :mod:`icidr_pde.rheology`, any object with
    ``symbolic_stress(phi, div_u, norm_S) -> (p, c)``, or such a callable."""
    if isinstance(law, (str, Rheology)):
        return toolkit_law(law, M_, Psi_, material)
    if hasattr(law, "symbolic_stress"):
        return law
    if callable(law):
        return InvariantLaw(getattr(law, "__name__", "law"), law)
    raise ValueError("`rheology` must be a registered name (e.g. 'mui', 'icidr'), an object with "
                     f"symbolic_stress(phi, div_u, norm_S) or a callable returning (p, c); got {law!r}")


def law_name(law) -> str:
    """Printable name of a law given to :func:`resolve_law`."""
    return law if isinstance(law, str) else str(getattr(law, "name", "") or getattr(law, "__name__", "law"))


# --- kinematics and the stress tensor ------------------------------------------------

def kinematics(grad_u=VELOCITY_GRADIENT):
    """D (2.4), div u, S (2.5) and ||S|| = sqrt(tr(S^2)/2) of a square velocity gradient.

    S = D - (div u/dim) I is trace-free in the gradient's own dimension: the paper's
    S = D - (div u/2) I for a 2x2 gradient, D - (div u/3) I for a 3x3 one (:mod:`stability.spatial`).
    """
    dim = grad_u.shape[0]
    D = (grad_u + grad_u.T) / 2
    div = D.trace()
    S = D - div / dim * sp.eye(dim)
    normS = sp.sqrt(sp.expand((S * S).trace() / 2))
    return {"D": D, "div": div, "S": S, "normS": normS}


def stress_tensor(law, grad_u=VELOCITY_GRADIENT, phi_=phi, M_=None, Psi_=None, material=None):
    """sigma = -p I + c S (2.3) for the law's (p, c) at the invariants of `grad_u`.

    The one place where a rheology becomes a stress tensor for this analysis (2-D here, 3-D
    with a 3x3 `grad_u`); a registered rheology comes from its one definition in
    :mod:`icidr_pde.rheology`.
    """
    k = kinematics(grad_u)
    p, c = resolve_law(law, M_, Psi_, material).symbolic_stress(phi_, k["div"], k["normS"])
    return -p * sp.eye(grad_u.shape[0]) + c * k["S"]


def principal_part(sigma, grad_u=VELOCITY_GRADIENT, phi_=phi):
    """a[i][j] = d sigma_ij/d phi /(rho phi), B[i][j][k][l] = d sigma_ij/d L_kl /(rho phi) (nested lists)."""
    den = rho * phi_
    r = range(grad_u.shape[0])
    a = [[sp.diff(sigma[i, j], phi_) / den for j in r] for i in r]
    B = [[[[sp.diff(sigma[i, j], grad_u[k, l]) / den for l in r] for k in r] for j in r] for i in r]
    return a, B


def acoustic_tensor(B, n):
    """Gamma_ik(n) = B_ijkl n_j n_l: the matrix multiplying -xi^2 in A(xi, n) ((A5) at n = e_z)."""
    r = range(len(n))
    return sp.Matrix(len(n), len(n), lambda i, k: sum(B[i][j][k][l] * n[j] * n[l] for j in r for l in r))


def phi_coupling(a, n):
    """alpha_i(n) = a_ij n_j: the i xi alpha phi terms of A(xi, n) ((a1, a2) of (A2) at n = e_z)."""
    r = range(len(n))
    return sp.Matrix([sum(a[i][j] * n[j] for j in r) for i in r])


def symbol_matrix(G, alpha, n, xi, phi_=phi):
    """A(xi, n) of the plane wave exp(i xi n.x + lambda t) ((A4) with w0 = 0 at n = e_z); 3x3 in 2-D, 4x4 in 3-D."""
    i = sp.I
    top = sp.Matrix([[0] + [-i * xi * phi_ * nj for nj in n]])
    return top.col_join((i * xi * alpha).row_join(-xi**2 * G))


def direction(angle=theta):
    """n = (cos theta, sin theta): theta = 90 deg is the 1-D direction e_z."""
    return sp.Matrix([sp.cos(angle), sp.sin(angle)])


# --- closed forms ------------------------------------------------------------------------

def invariant_gamma(p_of, c_of, n, grad_u=VELOCITY_GRADIENT, phi_=phi):
    """Closed form of rho phi Gamma(n) and rho phi alpha(n) for a law on invariants.

    ``p_of(phi, delta, s)``, ``c_of(...)`` give p and c; their partial derivatives are
    taken in (phi, delta, s) and evaluated at the invariants of `grad_u`:
    rho phi Gamma = (c/2) I - n (p_delta n + p_s m/(2s))^T + m (c_delta n + c_s m/(2s))^T,
    rho phi alpha = -p_phi n + c_phi m, with m = S n.  With a 3x3 `grad_u` and 3-vector `n`
    the trace-free part of dS/dL adds c (1/2 - 1/3) n n^T = (c/6) n n^T (:mod:`stability.spatial`);
    in 2-D that term is c (1/2 - 1/2) n n^T = 0.
    """
    k = kinematics(grad_u)
    s_ = sp.Symbol("s_", positive=True)
    dl = sp.Symbol("delta_", real=True)
    p, c = p_of(phi_, dl, s_), c_of(phi_, dl, s_)
    at = {dl: k["div"], s_: k["normS"]}

    def ev(e):
        return e.subs(at)

    m = k["S"] * n
    rowp = ev(sp.diff(p, dl)) * n.T + ev(sp.diff(p, s_) / (2 * s_)) * m.T
    rowc = ev(sp.diff(c, dl)) * n.T + ev(sp.diff(c, s_) / (2 * s_)) * m.T
    dim = len(n)
    G = ev(c) / 2 * sp.eye(dim) + ev(c) * (sp.Rational(1, 2) - sp.Rational(1, dim)) * n * n.T - n * rowp + m * rowc
    alpha = -ev(sp.diff(p, phi_)) * n + ev(sp.diff(c, phi_)) * m
    return G, alpha


def mui_eigen_closed_form(n, grad_u=VELOCITY_GRADIENT, M_=M, Psi_=Psi):
    """Eigenvalues of -Gamma(n) for mu(I): (4 d^2 s/(phi Psi^2)) (n.S n/s - M) and -(2 d^2 s M/(phi Psi^2)).

    n.S n/s = cos 2(theta - beta), beta the principal stretching direction of S.
    """
    k = kinematics(grad_u)
    s = k["normS"]
    pref = 4 * d**2 * s / (phi * Psi_**2)
    return pref * ((n.T * k["S"] * n)[0, 0] / s - M_), -pref * M_ / 2


def icidr_gamma_closed_form(n, grad_u=VELOCITY_GRADIENT, M_=M, Psi_=Psi):
    """Gamma(n) of iCIDR as K/(rho phi) [(q/2) I + (2/R) w w^T] (see module docstring); returns (Gamma, q, R, w)."""
    k = kinematics(grad_u)
    dl, s = k["div"], k["normS"]
    R = sp.sqrt(dl**2 + M_**2 * s**2)
    q = R - dl
    K = 4 * rho * d**2 / Psi_**2
    w = q / M_ * n - M_ / 2 * (k["S"] * n)
    return K / (rho * phi) * (q / 2 * sp.eye(2) + 2 / R * w * w.T), q, R, w


# --- exact checks -----------------------------------------------------------------------

def gradient_parametrisation():
    """grad u in terms of (div u, ||S||, vorticity, principal direction): rational, ||S|| a symbol.

    L = (delta/2) I + s [[cos 2b, sin 2b], [sin 2b, -cos 2b]] + omega [[0, 1], [-1, 0]] with
    (cos 2b, sin 2b) = ((1 - y^2), 2y)/(1 + y^2); covers every gradient with ||S|| = s > 0
    (the direction y -> oo by continuity).
    """
    s = sp.Symbol("s", positive=True)
    om, y = sp.symbols("omega y", real=True)
    c2, s2 = (1 - y**2) / (1 + y**2), 2 * y / (1 + y**2)
    subs = {ux: delta / 2 + s * c2, wz: delta / 2 - s * c2, uz: s * s2 + om, wx: s * s2 - om}
    return subs, s


def _clean_roots(expr, rad=None, R=None):
    """Factor the radicand of every square root; optionally replace sqrt(k^2 rad) by k R."""
    def repl(e):
        b = sp.factor(e.base)
        if rad is not None:
            ratio = sp.factor(b / rad)
            if not ratio.free_symbols & (rad.free_symbols | {ux, uz, wx, wz}):
                return sp.Pow(ratio, e.exp) * R ** (2 * e.exp)
        return sp.Pow(b, e.exp)

    return expr.replace(lambda e: e.is_Pow and e.exp.is_Rational and e.exp.q == 2, repl)


def _vanishes(expr, subs, rad=None, R=None):
    """expr == 0 identically on the parametrised gradients (reduced modulo R^2 = rad if given)."""
    e = sp.together(_clean_roots(sp.together(expr.subs(subs)), rad, R))
    num = sp.expand(sp.fraction(e)[0])
    if R is None:
        return num == 0
    rem = sp.Poly(num, R).rem(sp.Poly(R**2 - rad, R))
    return all(sp.expand(cf) == 0 for cf in rem.all_coeffs())


ROOT_R = sp.Symbol("R", positive=True)      # sqrt(div^2 + M^2 ||S||^2) of (4.12), in the iCIDR proof


@lru_cache(maxsize=None)
def point_gamma(name: str):
    """Gamma(n) for `name` on the parametrised gradients of :func:`gradient_parametrisation`.

    M, Psi are plain symbols (Gamma needs no phi-derivative).  n = e_z suffices: the
    stress is built from the invariants and S, so sigma(Q L Q^T) = Q sigma(L) Q^T for every
    rotation Q and Gamma(Q n; Q L Q^T) = Q Gamma(n; L) Q^T, and the closed forms are
    covariant in the same way; the gradient stays general.  The four entries of grad u
    are differentiated first, then parametrised; sqrt(div^2 + M^2 s^2) becomes the
    symbol :data:`ROOT_R`.  Returns (Gamma, n).
    """
    n = sp.Matrix([0, 1])
    subs, s = gradient_parametrisation()
    rad = delta**2 + M**2 * s**2
    _, B = principal_part(stress_tensor(name, M_=M, Psi_=Psi))

    def param(e):
        return sp.cancel(_clean_roots(sp.together(e.subs(subs)), rad, ROOT_R))

    Bp = [[[[param(B[i][j][k][l]) for l in range(2)] for k in range(2)] for j in range(2)] for i in range(2)]
    return acoustic_tensor(Bp, n), n


def _check_theta90():
    from . import linearize, rheologies  # noqa: PLC0415
    ez = sp.Matrix([0, 1])
    at1d = {ux: 0, wx: 0}
    ok = True
    for name in ("mui", "icidr"):
        a, B = principal_part(stress_tensor(name))
        G = acoustic_tensor(B, ez).subs(at1d)
        al = phi_coupling(a, ez).subs(at1d)
        c1 = linearize.principal_coefficients(*rheologies.stress(name))
        G1 = linearize.gamma_matrix(c1)
        ok &= all(exact_zero(x) for x in (G - G1)) and exact_zero(al[0] - c1["a1"]) and exact_zero(al[1] - c1["a2"])
    return Check("2-D theta = 90", "n = e_z and grad u = [[0, u_z], [0, w_z]]: Gamma(n) = (A5), alpha(n) = "
                 "(a1, a2) of (A2), for mu(I) and iCIDR", EXACT if ok else FAILS,
                 "2-D tensor sigma = -p I + c S differentiated in the four entries of grad u vs the 1-D fluxes "
                 "(tau_xz, tau_zz - p) differentiated in (u_z, w_z)", section=SECTION)


def _check_invariant_form():
    Pf, Cf = sp.Function("P"), sp.Function("C")
    n = sp.Matrix([0, 1])                                    # every n by rotation covariance (point_gamma)
    gen = InvariantLaw("generic", lambda ph, dv, sn: (Pf(ph, dv, sn), Cf(ph, dv, sn)))
    a, B = principal_part(stress_tensor(gen))
    G = acoustic_tensor(B, n) * rho * phi
    al = phi_coupling(a, n) * rho * phi
    Gc, alc = invariant_gamma(lambda ph, dv, sn: Pf(ph, dv, sn), lambda ph, dv, sn: Cf(ph, dv, sn), n)
    ok = all(sp.simplify((x - y).doit()) == 0 for x, y in zip(list(G) + list(al), list(Gc) + list(alc)))
    return Check("2-D Gamma(n)", "any law sigma = -p(phi, div u, ||S||) I + c(...) S: rho phi Gamma(n) = (c/2) I "
                 "- n (p_div n + p_s S n/(2||S||))^T + S n (c_div n + c_s S n/(2||S||))^T, rho phi alpha(n) = "
                 "-p_phi n + c_phi S n", EXACT if ok else FAILS,
                 "generic functions P, C of (phi, div u, ||S||), general grad u, n = e_z (every n by rotation covariance)", section=SECTION)


def _check_mui():
    G, n = point_gamma("mui")
    subs, s = gradient_parametrisation()
    l1, l2 = (e.subs(subs) for e in mui_eigen_closed_form(n))
    ok = _vanishes(G.trace() + l1 + l2, subs) and _vanishes(G.det() - l1 * l2, subs)
    S = kinematics()["S"].subs(subs)
    beta = sp.Matrix([1, sp.Symbol("y", real=True)])          # principal stretching direction (unnormalised)
    okb = all(sp.simplify(x) == 0 for x in (S * beta - s * beta))
    return Check("2-D mu(I) eig", "mu(I),Phi(I): eig(-Gamma(n)) = (4 d^2 ||S||/(phi Psi^2)) (n.S n/||S|| - M) "
                 "and -2 d^2 ||S|| M/(phi Psi^2); n.S n/||S|| = cos 2(theta - beta) reaches 1 at the principal "
                 "stretching direction beta, so with M = mu(Psi) < 1 every shearing state (||S|| > 0) has the "
                 "ill-posed interval |theta - beta| < arccos(M)/2 (mod 180 deg), whatever div u and the vorticity",
                 EXACT if ok and okb else FAILS,
                 "tr Gamma and det Gamma equal -(sum) and the product of the two roots for every grad u = "
                 "(div/2) I + S + omega J (rational parametrisation) at n = e_z, hence for every n by rotation "
                 "covariance; S (1, y) = ||S|| (1, y)",
                 section=SECTION)


def _check_icidr():
    G, n = point_gamma("icidr")
    subs, s = gradient_parametrisation()
    Gc, q, R, w = (e.subs(subs) for e in icidr_gamma_closed_form(n))
    Rs = ROOT_R
    rad = delta**2 + M**2 * s**2
    ok = all(_vanishes(x.subs({d: 1, rho: 1}), subs, rad, Rs) for x in (G - Gc))
    wperp = sp.Matrix([-w[1], w[0]])
    okev = all(_vanishes(x.subs({d: 1, rho: 1}), subs, rad, Rs)
               for x in (Gc * wperp - (2 * d**2 * q / (phi * Psi**2)) * wperp))
    return Check("2-D iCIDR Gamma", "iCIDR: Gamma(n) = K/(rho phi) [(q/2) I + (2/R) w w^T], K = 4 rho d^2/Psi^2, "
                 "R = sqrt(div^2 + M^2||S||^2), q = R - div, w = (q/M) n - (M/2) S n: symmetric, positive "
                 "definite iff q > 0 (||S|| > 0 or div u < 0), smallest eigenvalue 2 d^2 q/(phi Psi^2) "
                 "(eigenvector w^perp) for every n, so Lambda_max(theta) = -2 d^2 (R - div u)/(phi Psi^2) < 0",
                 EXACT if ok and okev else FAILS,
                 "entries of Gamma - closed form reduce to 0 modulo R^2 = div^2 + M^2||S||^2 for every grad u "
                 "with ||S|| > 0 at n = e_z, hence every n by rotation covariance; Gamma w^perp = 2 d^2 q/(phi Psi^2) w^perp; R >= |div u| with equality "
                 "iff M||S|| = 0, so q > 0 unless ||S|| = 0 and div u >= 0 (then p = 0 by (4.13)); at ||S|| = 0, "
                 "div u < 0 the closed form is the continuous limit", section=SECTION)


def checks() -> list[Check]:
    """Exact checks of the 2-D principal part and its closed forms (see module docstring)."""
    return [_check_theta90(), _check_invariant_form(), _check_mui(), _check_icidr()]
