"""Incompressible mu(I) (Jop, Forterre & Pouliquen 2006) in 2-D: the criterion of Barker et al. (2015), derived.

The equations are ``rho (u_t + u.grad u) = -grad p + div tau``, ``div u = 0``, with the
alignment law (2.6) and (2.7), ``tau = mu(I) p S/||S||``, and (2.9), ``I = 2 d ||S||/sqrt(p/rho)``
(||T|| = sqrt(tr(T^2)/2) as everywhere here; d = rho = 1). The pressure is no longer a
function of the state: it is the Lagrange multiplier of div u = 0. The same friction law
mu(I) as the compressible mu(I),Phi(I) and the CIDR laws comes from the simulator's
:class:`~icidr_pde.rheology.Material` (e.g. the non-monotonic one of section 7.3).

**Principal symbol** (:func:`sigma`; T = d tau/d L and b = d tau/d p by sympy differentiation of
tau(L, p), no coefficient typed in). About a uniform state with velocity gradient L (trace 0)
and pressure p, a plane wave ``exp(i xi n.x + lambda t)`` of (u', p') with n = (cos theta,
sin theta) has u' = a t, t = (-sin theta, cos theta) (div u' = 0), so grad u' = i xi a t n^T and
tau' = i xi a T:(t n^T) + b p':

* the n-component of momentum balances the pressure: (1 - n.b.n) p' = i xi a n.(T:t n^T).n,
  so p' = O(xi) and b p' enters at the order xi^2 of the viscous term;
* the t-component gives rho lambda = -xi^2 sigma(n) with

      sigma(n) = t.(T:t n^T).n + (t.b.n) n.(T:t n^T).n/(1 - n.b.n).

:func:`growth_rate` solves the whole frozen-coefficient linearisation (with the O(1) term
L u' and the constraint) as a generalised eigenproblem at finite xi; its max Re lambda/xi^2
tends to -sigma like 1/xi^2 (tested).

The equations are ill-posed iff sigma(n) < 0 for some direction (growth ~ xi^2, without bound).

**Closed form** (checked against the derivation in the tests). Simple shear, S = ||S|| [[0, 1], [1, 0]],
nu = I mu'(I)/mu (the friction slope), m = mu (1 - nu/2) (= n.b.n/sin 2 theta) and s = sin 2 theta:

    sigma = (mu p/(2||S||)) N(s)/(1 - m s),    N(s) = (1 - nu) s^2 - m s + nu,

so (with mu < 1, hence 1 - m s > 0) the law is ill-posed iff N < 0 somewhere on [-1, 1]:

* nu < 0 (friction *decreasing* with I): N(0) = nu < 0, ill-posed whatever mu (the shear
  perturbation along the flow, s = 0, has negative differential viscosity);
* 0 <= nu < 1 with the minimiser s* = m/(2(1 - nu)) in [-1, 1]: ill-posed iff
  N(s*) = nu - m^2/(4(1 - nu)) < 0, i.e. iff ``4 nu^2 - 4 nu + mu^2 (1 - nu/2)^2 > 0`` -- the
  criterion of Barker, Schaeffer, Bohorquez & Gray (2015, JFM 779), whose well-posed set is
  where this is < 0 (:func:`barker_criterion`); s* <= 1 whenever nu <= 1/2, which covers every
  state of the laws here (nu <= 0.22 for (2.10) and the non-monotonic mu);
* otherwise (s* > 1, or nu >= 1) N >= 1 - m > 0 on [-1, 1]: well-posed.

So at small I (nu -> 0, the quasi-static end) incompressible mu(I) with (2.10) is ill-posed,
and with the non-monotonic friction it is ill-posed on the whole decreasing branch I < I_min.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import sympy as sp

__all__ = ["sigma", "growth_rate", "sigma_closed_form", "friction_slope", "barker_criterion", "ill_posed",
           "well_posed_intervals"]

_I = sp.Symbol("I", positive=True)


def _material(material):
    from icidr_pde.rheology import Material

    return Material() if material is None else material


@lru_cache(maxsize=None)
def _linear_parts(friction_key):
    """T = d tau/d L (2x2x2x2) and b = d tau/d p at simple shear u = z (||S|| = 1/2), p = 1/I^2,
    as a numpy function of (I, parameters): sympy derivatives of tau(L, p), nothing typed in."""
    material = _material_of(friction_key)
    prm = material.values(symbolic=True)
    names = material.parameter_names()
    L = sp.Matrix(2, 2, sp.symbols("L_xx L_xz L_zx L_zz", real=True))
    p, I = sp.symbols("p I", positive=True)  # noqa: E741
    D = (L + L.T) / 2
    S = D - D.trace() / 2 * sp.eye(2)
    normS = sp.sqrt((S * S).trace() / 2)
    mu = material.symbolic_mu(_I, True).xreplace({_I: 2 * normS / sp.sqrt(p)})   # (2.9), d = rho = 1
    tau = mu * p * S / normS                                                   # (2.6)-(2.7)
    base = {L[0, 0]: 0, L[0, 1]: 1, L[1, 0]: 0, L[1, 1]: 0}
    T = [[[[sp.diff(tau[i, j], L[k, m]).subs(base).subs(p, 1 / I**2) for m in range(2)] for k in range(2)]
          for j in range(2)] for i in range(2)]
    b = [[sp.diff(tau[i, j], p).subs(base).subs(p, 1 / I**2) for j in range(2)] for i in range(2)]
    f = sp.lambdify((I, *[prm[k] for k in names]), (T, b), modules="numpy")

    def parts(I_value):
        T_v, b_v = f(float(I_value), *material.params)
        return np.array(T_v, float), np.array(b_v, float)

    return parts


_MATERIALS: dict = {}


def _material_of(key):
    return _MATERIALS[key]


def _key(material):
    key = material.law_key() + (material.params,)
    _MATERIALS[key] = material
    return key


def _directions(theta):
    return np.array([np.cos(theta), np.sin(theta)]), np.array([-np.sin(theta), np.cos(theta)])


def sigma(I, theta_deg, material=None):  # noqa: E741
    """sigma(n) of the incompressible mu(I) symbol at inertial number I, n at angle theta (degrees),
    simple shear u = z (||S|| = 1/2, p = 1/I^2); rho lambda = -xi^2 sigma. From the derivation."""
    material = _material(material)
    parts = _linear_parts(_key(material))
    I, th = np.broadcast_arrays(np.asarray(I, float), np.deg2rad(np.asarray(theta_deg, float)))
    out = np.empty(I.shape)
    for value in np.unique(I):
        at = I == value
        T, b = parts(value)
        n, t = _directions(th[at])                                   # (2, k) each
        TdL = np.einsum("ijkm,kq,mq->ijq", T, t, n)                  # T : (t n^T), per direction
        tTn = np.einsum("iq,ijq,jq->q", t, TdL, n)
        nTn = np.einsum("iq,ijq,jq->q", n, TdL, n)
        tbn, nbn = np.einsum("iq,ij,jq->q", t, b, n), np.einsum("iq,ij,jq->q", n, b, n)
        out[at] = tTn + tbn * nTn / (1 - nbn)
    return out


def growth_rate(I, theta_deg, xi, material=None):  # noqa: E741
    """max Re lambda of the full frozen-coefficient linearisation at wavenumber xi (not only its
    principal part): rho (lambda + i xi n.u0) u' = -L u' - i xi n p' + i xi tau'(u', p') n, n.u' = 0,
    as the generalised eigenproblem in (u', p') (the state of :func:`sigma`; u0 = 0 at the origin)."""
    from scipy.linalg import eig

    material = _material(material)
    T, b = _linear_parts(_key(material))(float(I))
    n, _ = _directions(np.deg2rad(float(theta_deg)))
    L = np.array([[0.0, 1.0], [0.0, 0.0]])
    A = np.zeros((3, 3), complex)
    # momentum: lambda u_i = -L_ik u_k - i xi n_i p + i xi [T_ijkm (i xi u_k n_m) + b_ij p] n_j
    A[:2, :2] = -L - xi**2 * np.einsum("ijkm,m,j->ik", T, n, n)
    A[:2, 2] = -1j * xi * n + 1j * xi * b @ n
    A[2, :2] = 1j * xi * n                                           # div u' = 0
    B = np.diag([1.0, 1.0, 0.0])
    lam = eig(A, B, right=False)
    lam = lam[np.isfinite(lam)]
    return float(np.max(lam.real))


def friction_slope(I, material=None):  # noqa: E741
    """(nu, mu) with nu = I mu'(I)/mu(I), from the material's friction law."""
    material = _material(material)
    names = material.parameter_names()
    prm = material.values(symbolic=True)
    mu = material.symbolic_mu(_I, True)
    f = sp.lambdify((_I, *[prm[k] for k in names]), (_I * sp.diff(mu, _I) / mu, mu), modules="numpy")
    nu, m = f(np.asarray(I, float), *material.params)
    return np.asarray(nu, float), np.asarray(m, float)


def sigma_closed_form(I, theta_deg, material=None):  # noqa: E741
    """The closed form of the module docstring at the state of :func:`sigma` (||S|| = 1/2, p = 1/I^2)."""
    nu, mu = friction_slope(I, material)
    s = np.sin(2 * np.deg2rad(np.asarray(theta_deg, float)))
    m = mu * (1 - nu / 2)
    p, norm_S = 1 / np.asarray(I, float) ** 2, 0.5
    return mu * p / (2 * norm_S) * ((1 - nu) * s**2 - m * s + nu) / (1 - m * s)


def barker_criterion(I, material=None):  # noqa: E741
    """4 nu^2 - 4 nu + mu^2 (1 - nu/2)^2 (Barker et al. 2015): < 0 well-posed, > 0 ill-posed (0 <= nu <= 1/2)."""
    nu, mu = friction_slope(I, material)
    return 4 * nu**2 - 4 * nu + mu**2 * (1 - nu / 2) ** 2


def ill_posed(I, material=None):  # noqa: E741
    """True where incompressible mu(I) is ill-posed: min over directions of N(s) < 0 (closed form)."""
    nu, mu = friction_slope(I, material)
    m = mu * (1 - nu / 2)
    s_star = np.clip(m / (2 * np.maximum(1 - nu, 1e-300)), -1, 1)
    s = np.where(nu < 1, s_star, 1.0)
    N = (1 - nu) * s**2 - m * s + nu
    return np.minimum(N, np.minimum(1 - m, 1 + m)) < 0


def well_posed_intervals(material=None, I_range=(1e-6, 10.0), n=4001):
    """Intervals of I (log-sampled on `I_range`, ends refined by bisection) where the law is well-posed."""
    I = np.logspace(np.log10(I_range[0]), np.log10(I_range[1]), n)  # noqa: E741
    bad = ill_posed(I, material)
    out, start = [], None
    for k in range(n):
        if not bad[k] and start is None:
            start = I[0] if k == 0 else _bisect(I[k - 1], I[k], material)
        if bad[k] and start is not None:
            out.append((float(start), float(_bisect(I[k - 1], I[k], material))))
            start = None
    if start is not None:
        out.append((float(start), float(I[-1])))
    return out


def _bisect(a, b, material, iterations=60):
    fa = bool(ill_posed(np.array([a]), material)[0])
    for _ in range(iterations):
        c = np.sqrt(a * b)
        if bool(ill_posed(np.array([c]), material)[0]) == fa:
            a = c
        else:
            b = c
    return np.sqrt(a * b)
