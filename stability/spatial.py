"""Well-posedness in three dimensions: plane waves in every direction n of the unit sphere.

The paper's laws are tensorial and its claim is well-posedness "for all deformations";
:mod:`stability.plane` checks wave directions in the x-z plane with the 2-D conventions.
Here the same law objects are made a 3-D stress with the 3-D conventions

    D = (L + L^T)/2,   S = D - (div u/3) I,   ||T|| = sqrt(tr(T^2)/2),
    sigma = -p I + tau,   tau = c S (trace-free),   (p, c) = law(phi, div u, ||S||),

for any 3x3 velocity gradient ``L[i, j] = d_j u_i`` (coordinates (x, y, z), velocity
(u, v, w)), by :func:`stability.plane.stress_tensor` with a 3x3 gradient: nothing is typed in.
Linearised and frozen as in :mod:`stability.plane`, a plane wave ``exp(i xi n.x + lambda t)``,
|n| = 1, has the 4x4 symbol (unknowns phi, u, v, w)

    A(xi, n) = [[0, -i xi phi0 n^T], [i xi alpha(n), -xi^2 Gamma(n)]],
    Gamma_ik(n) = B_ijkl n_j n_l,   alpha_i(n) = a_ij n_j,

and the rate of the short waves in direction n is ``Lambda_max(n) = max Re eig(-Gamma(n))``
(lambda ~ Lambda_max xi^2): the system is ill-posed where some n has Lambda_max(n) > 0.

Closed form (any law on invariants; m = S n, s = ||S||, proved in :func:`checks`):
``rho phi Gamma = (c/2) I + (c/6) n n^T - n (p_div n + p_s m/(2s))^T + m (c_div n + c_s m/(2s))^T``,
``rho phi alpha = -p_phi n + c_phi m``.  The term (c/6) n n^T is c (1/2 - 1/dim) n n^T
from dS/dL = sym - (1/dim) I (x) I; in 2-D it is c (1/2 - 1/2) = 0.

**What the 3-D deviator changes in the x-z plane.**  Take a planar deformation
(L with no y row or column) and n in the x-z plane.  Then Gamma is block diagonal: the
y velocity decouples with Gamma_yy = c/(2 rho phi) (a shear wave, stable when c > 0), and
the x-z block is the 2-D closed form of :mod:`stability.plane` *plus* (c/(6 rho phi)) n n^T,
evaluated at the 3-D invariants.  These differ from the 2-D ones only when div u != 0:
S_3 = S_2 + (div u/6) I on the x-z block, S_yy = -div u/3, ||S_3||^2 = ||S_2||^2 + div u^2/12.
So at an isochoric state (div u = 0, e.g. steady shear) the 3-D symbol restricted to the
plane is the 2-D one plus c/(6 rho phi) n n^T: a stiffer longitudinal response.  For
mu(I),Phi(I) (c = M p/s, p = rho (2 d s/Psi)^2) at the principal stretching direction
(m = s n) the ill-posed eigenvalue of -Gamma drops from (4 d^2 s/(phi Psi^2)) (1 - M) (2-D)
to (4 d^2 s/(phi Psi^2)) (1 - 7M/6) (3-D): the in-plane instability needs M < 6/7 instead of
M < 1, and the ill-posed directions, C = cos 2(theta - beta) > M in 2-D, become
M C^2 + 6 C - 8 M > 0, i.e. C > (sqrt(8 M^2 + 9) - 3)/M: a narrower interval (numbers for
Table 1 in docs/plane_waves.md).  In the steady shear computed there the worst direction
stays in the plane, and off-plane directions are ill-posed too: a pair of caps on the sphere,
not an interval.

Numbers (:func:`spatial_stability`): the coefficients are compiled once per law with
``sympy.lambdify`` (d = rho_* = 1, as :mod:`stability.directional`); Lambda_max is sampled on a
Fibonacci lattice of `directions` points of the sphere (area 4 pi/N each, spacing about
sqrt(4 pi/N) rad: 4.5 deg at the default 2000), ``ill_posed_fraction`` is the fraction of
those points with Lambda_max > 0 (beyond round-off: 1e-12 max|Gamma|), and the worst
direction is the best sample refined by a Nelder-Mead maximisation in (polar, azimuth).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import sympy as sp

from . import directional, plane
from .checks import EXACT, FAILS, Check
from .material import RATE_RANGE, check_phi
from .symbols import Psi, phi, rho, uz, wz

SECTION = "3-D plane waves"

ux, wx = plane.ux, plane.wx
uy, vx, vy, vz, wy = sp.symbols("u_y v_x v_y v_z w_y", real=True)
#: the base velocity gradient L[i, j] = d_j u_i (rows u, v, w; columns x, y, z); the 2-D one is its x-z block
VELOCITY_GRADIENT = sp.ImmutableMatrix([[ux, uy, uz], [vx, vy, vz], [wx, wy, wz]])
GRADIENT_NAMES = tuple(str(s) for s in VELOCITY_GRADIENT)
#: a planar deformation: velocity (u, 0, w) independent of y
PLANAR = {uy: 0, vx: 0, vy: 0, vz: 0, wy: 0}
#: default number of Fibonacci directions on the sphere
DIRECTIONS = 2000
MAX_DIRECTIONS = 1_000_000


# --- symbolic ---------------------------------------------------------------------------------

def stress_tensor(law, grad_u=VELOCITY_GRADIENT, phi_=phi, M_=None, Psi_=None, material=None):
    """sigma = -p I + c S with the 3-D conventions, from the law's one definition (:func:`stability.plane.stress_tensor`)."""
    return plane.stress_tensor(law, sp.Matrix(grad_u), phi_, M_, Psi_, material)


def principal_part(sigma, grad_u=VELOCITY_GRADIENT, phi_=phi):
    """a (3x3) and B (3x3x3x3) of the 3-D stress (nested lists; :func:`stability.plane.principal_part`)."""
    return plane.principal_part(sigma, sp.Matrix(grad_u), phi_)


def direction(polar=sp.Symbol("vartheta", real=True), azimuth=sp.Symbol("varphi", real=True)):
    """n = (sin polar cos azimuth, sin polar sin azimuth, cos polar); azimuth 0 is the x-z plane."""
    return sp.Matrix([sp.sin(polar) * sp.cos(azimuth), sp.sin(polar) * sp.sin(azimuth), sp.cos(polar)])


def symbol(law, n=None, xi=sp.Symbol("xi", positive=True), grad_u=VELOCITY_GRADIENT, **law_kw):
    """The 4x4 symbol A(xi, n) (unknowns phi, u, v, w) of `law` at the symbolic 3-D state."""
    n = direction() if n is None else sp.Matrix(n)
    a, B = principal_part(stress_tensor(law, grad_u, **law_kw), grad_u)
    return plane.symbol_matrix(plane.acoustic_tensor(B, n), plane.phi_coupling(a, n), n, xi)


# --- numbers at one state ----------------------------------------------------------------------

def check_gradient(velocity_gradient) -> np.ndarray:
    """A 3x3 velocity gradient L[i, j] = d_j u_i from 9 numbers (row-major) or a 3x3 array: finite, each 0 or
    of magnitude in :data:`~stability.material.RATE_RANGE`, not all zero."""
    low, high = RATE_RANGE
    wanted = (f"`velocity_gradient` must be 9 numbers ({', '.join(GRADIENT_NAMES)}) or a 3x3 array, each 0 or of "
              f"magnitude in [{low:g}, {high:g}]")
    try:
        L = np.array(velocity_gradient, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{wanted}; got {velocity_gradient!r}") from None
    if L.size != 9 or L.ndim not in (1, 2) or not np.all(np.isfinite(L)):
        raise ValueError(f"{wanted}; got {velocity_gradient!r}")
    L = L.reshape(3, 3)
    size = np.abs(L)
    if np.any((size != 0) & ((size < low) | (size > high))):
        raise ValueError(f"{wanted}; got {velocity_gradient!r}")
    if not L.any():
        raise ValueError("`velocity_gradient` must not be zero: at zero strain rate Gamma = 0 and the system is "
                         "degenerate; got 0")
    return L


def planar_gradient(ux_, uz_, wx_, wz_) -> np.ndarray:
    """The 3x3 gradient of the 2-D gradient [[u_x, u_z], [w_x, w_z]]: velocity (u, 0, w), independent of y."""
    return np.array([[ux_, 0.0, uz_], [0.0, 0.0, 0.0], [wx_, 0.0, wz_]], dtype=float)


def strain_rate_norm(L) -> float:
    """||S|| = sqrt(tr(S^2)/2) with the 3-D deviator S = D - (div u/3) I."""
    L = np.asarray(L, dtype=float)
    D = (L + L.T) / 2
    S = D - np.trace(D) / 3 * np.eye(3)
    return float(np.sqrt(np.sum(S * S) / 2))


def principal_part_at(rheology, phi0, velocity_gradient, material=None):
    """Numeric a (3, 3), B (3, 3, 3, 3) of the 3-D stress of `rheology` at (phi0, L).

    Raises ValueError for phi outside the law's range, a bad gradient, or a state where the
    law is not differentiable (non-finite coefficients, e.g. mu(I) at ||S|| = 0).
    """
    law = directional._law(rheology)
    phi0 = float(check_phi(phi0, material))
    L = check_gradient(velocity_gradient)
    f, params = directional.compiled("principal", law, material, VELOCITY_GRADIENT)
    with np.errstate(all="ignore"):
        vals = np.array(f(phi0, *L.ravel(), *params), dtype=float)
    if not np.all(np.isfinite(vals)):
        raise ValueError(f"`velocity_gradient` = {L.tolist()}: the stress of {plane.law_name(law)!r} is not "
                         f"differentiable there (||S|| = {strain_rate_norm(L):g}); choose a state where it is")
    return vals[:9].reshape(3, 3), vals[9:].reshape(3, 3, 3, 3)


def stress_at(rheology, phi0, velocity_gradient, material=None) -> np.ndarray:
    """The 3-D stress sigma (3, 3) of `rheology` at (phi0, L) (d = rho_* = 1)."""
    law = directional._law(rheology)
    phi0 = float(check_phi(phi0, material))
    L = check_gradient(velocity_gradient)
    f, params = directional.compiled("stress", law, material, VELOCITY_GRADIENT)
    with np.errstate(all="ignore"):
        return np.array(f(phi0, *L.ravel(), *params), dtype=float).reshape(3, 3)


def sphere_directions(count=DIRECTIONS) -> np.ndarray:
    """`count` unit vectors of the Fibonacci lattice on the sphere (shape (count, 3)), nearly equal areas 4 pi/count."""
    k = np.arange(count) + 0.5
    cos_polar = 1 - 2 * k / count
    azimuth = math.pi * (1 + math.sqrt(5)) * k
    sin_polar = np.sqrt(1 - cos_polar**2)
    return np.stack([sin_polar * np.cos(azimuth), sin_polar * np.sin(azimuth), cos_polar], -1)


def unit(polar, azimuth) -> np.ndarray:
    """n of :func:`direction`, numeric (arrays broadcast; shape (..., 3))."""
    polar, azimuth = np.asarray(polar, float), np.asarray(azimuth, float)
    return np.stack([np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth), np.cos(polar)], -1)


def gamma_alpha(a, B, n):
    """Gamma(n) (k, 3, 3) and alpha(n) (k, 3) for unit vectors n (k, 3)."""
    n = np.atleast_2d(n)
    return np.einsum("ijkl,aj,al->aik", B, n, n), np.einsum("ij,aj->ai", a, n)


def lambda_max(a, B, n) -> np.ndarray:
    """max Re eig(-Gamma(n)) for unit vectors n (k, 3): the short-wave rate lambda/xi^2 in direction n."""
    G, _ = gamma_alpha(a, B, n)
    return np.linalg.eigvals(-G).real.max(axis=-1)


def symbol_matrix(a, B, phi0, xi, n) -> np.ndarray:
    """A(xi, n) (4x4, unknowns phi, u, v, w) of :func:`symbol`, numeric, one direction."""
    n = np.asarray(n, float)
    G, al = gamma_alpha(a, B, n[None])
    A = np.zeros((4, 4), dtype=complex)
    A[0, 1:] = -1j * xi * phi0 * n
    A[1:, 0] = 1j * xi * al[0]
    A[1:, 1:] = -xi**2 * G[0]
    return A


@dataclass
class SpatialStability:
    """Plane-wave numbers of one law at one uniform 3-D state, over the sphere of directions."""

    rheology: str
    phi: float
    velocity_gradient: np.ndarray
    directions: int
    max_lambda: float
    worst_direction: np.ndarray
    ill_posed_fraction: float
    lambda_max: np.ndarray = field(repr=False)
    sample: np.ndarray = field(repr=False)
    tolerance: float = 0.0

    @property
    def well_posed(self) -> bool:
        """True if no sampled direction has Lambda_max > 0 (beyond round-off) and neither has the refined worst one."""
        return self.ill_posed_fraction == 0.0 and not self.max_lambda > self.tolerance

    @property
    def spacing_deg(self) -> float:
        """Typical spacing of the Fibonacci directions, sqrt(4 pi/N) in degrees."""
        return math.degrees(math.sqrt(4 * math.pi / self.directions))

    def to_json(self) -> dict:
        n = self.worst_direction
        return {"rheology": self.rheology, "phi": self.phi, "dim": 3,
                "velocity_gradient": {k: float(v) for k, v in zip(GRADIENT_NAMES, self.velocity_gradient.ravel())},
                "max_lambda": self.max_lambda,
                "worst_direction": [float(v) for v in n],
                "worst_direction_deg": {"polar": math.degrees(math.acos(max(-1.0, min(1.0, n[2])))),
                                        "azimuth": math.degrees(math.atan2(n[1], n[0])) % 360.0},
                "ill_posed_fraction": self.ill_posed_fraction, "well_posed": self.well_posed,
                "sampling": {"method": "Fibonacci lattice on the unit sphere", "directions": self.directions,
                             "spacing_deg": self.spacing_deg,
                             "ill_posed_where": "Lambda_max(n) > 1e-12 max|Gamma|"}}


def spatial_stability(rheology, phi0, velocity_gradient, directions=DIRECTIONS, material=None) -> SpatialStability:
    """Plane-wave analysis of `rheology` at (phi0, L) over `directions` Fibonacci directions of the sphere.

    Returns a :class:`SpatialStability`: the largest rate ``max_lambda`` = max_n Lambda_max(n)
    and its ``worst_direction``, and ``ill_posed_fraction``. Raises ValueError (naming the
    parameter) on bad input and for a degenerate state (Gamma = 0 in every direction).
    """
    if isinstance(directions, bool) or not isinstance(directions, (int, np.integer)) \
            or not 12 <= directions <= MAX_DIRECTIONS:
        raise ValueError(f"`directions` must be an integer in [12, {MAX_DIRECTIONS}]; got {directions!r}")
    L = check_gradient(velocity_gradient)
    a, B = principal_part_at(rheology, phi0, L, material)
    n = sphere_directions(int(directions))
    G, _ = gamma_alpha(a, B, n)
    scale = float(np.abs(G).max())
    if scale == 0.0:
        raise ValueError(f"`velocity_gradient` = {L.tolist()}: Gamma = 0 in every direction (degenerate state, "
                         "e.g. iCIDR with ||S|| = 0 and div u >= 0, where p = 0 by (4.13))")
    lam = np.linalg.eigvals(-G).real.max(axis=-1)
    tol = 1e-12 * scale
    worst, best = _refine_max(a, B, n, lam)
    return SpatialStability(plane.law_name(rheology), float(phi0), L, int(directions), best, worst,
                            float(np.mean(lam > tol)), lam, n, tol)


def _refine_max(a, B, n, lam):
    """(unit vector, rate) of the sampled maximum refined by Nelder-Mead in (polar, azimuth); n and -n are one."""
    from scipy.optimize import minimize  # noqa: PLC0415

    i = int(np.argmax(lam))
    n0, best = n[i], float(lam[i])
    x0 = [math.acos(max(-1.0, min(1.0, n0[2]))), math.atan2(n0[1], n0[0])]
    res = minimize(lambda x: -float(lambda_max(a, B, unit(*x)[None])[0]), x0, method="Nelder-Mead",
                   options={"xatol": 1e-10, "fatol": 1e-15 * max(1.0, abs(best)), "maxiter": 400})
    if -res.fun > best:
        n0, best = unit(*res.x), float(-res.fun)
    if n0[2] < 0 or (n0[2] == 0 and n0[0] < 0):      # report the representative with n_z >= 0
        n0 = -n0
    return n0, best


def ill_posed_fraction(rheology, phi0, velocity_gradient, directions=DIRECTIONS, material=None) -> float:
    """Fraction of the sphere of wave directions where Lambda_max(n) > 0, on `directions` Fibonacci points."""
    return spatial_stability(rheology, phi0, velocity_gradient, directions, material).ill_posed_fraction


# --- from the invariant kernels (the workbench's grid) ------------------------------------------

def invariant_gamma(c, p_div, p_s, c_div, c_s, norm_S, S, n, phi_):
    """Gamma(n) of the closed form (module docstring) from (c, p_div, p_s, c_div, c_s) at one state per row.

    Shapes: c, ... norm_S, phi_ (k,), S (k, 3, 3) trace-free, n (m, 3); returns (k, m, 3, 3) with rho_* = 1.
    """
    m = np.einsum("kij,aj->kai", S, n)
    nn = np.broadcast_to(n[None], m.shape)
    s2 = (2 * norm_S)[:, None, None]
    left_p = p_div[:, None, None] * nn + p_s[:, None, None] * m / s2
    left_c = c_div[:, None, None] * nn + c_s[:, None, None] * m / s2
    G = (c[:, None, None, None] / 2) * np.eye(3) + (c[:, None, None, None] / 6) * nn[..., :, None] * nn[..., None, :] \
        - nn[..., :, None] * left_p[..., None, :] + m[..., :, None] * left_c[..., None, :]
    return G / phi_[:, None, None, None]


def deviator_of_shape(norm_S, lode) -> np.ndarray:
    """Diagonal trace-free S with ||S|| = norm_S and eigenvalues (2 s/sqrt 3) cos(lode - 2 pi k/3), k = 0, 1, 2.

    lode = 0: axisymmetric extension; pi/6: planar shear (eigenvalues s, 0, -s); pi/3: axisymmetric
    compression. By isotropy every deviator is a rotation of one of these (lode in [0, pi/3]).
    """
    norm_S, lode = np.broadcast_arrays(np.asarray(norm_S, float), np.asarray(lode, float))
    ev = 2 * norm_S[..., None] / math.sqrt(3) * np.cos(lode[..., None] - 2 * math.pi * np.arange(3) / 3)
    return ev[..., :, None] * np.eye(3)


#: the workbench's 3-D grid: its 2-D states times these deviator shapes, directions on the sphere
GRID_3D = {"lode_deg": (0.0, 15.0, 30.0, 45.0, 60.0), "directions": 400}


def grid_symbol(rheology, states) -> dict:
    """The 3-D verdict over `states`, arrays (phi, gamma-dot, div u/||S||) of 2-D states (the
    workbench's grid: :func:`stability.workbench.symbol_grid`), times the deviator shapes of
    :data:`GRID_3D`, each over the sphere of directions.

    Gamma(n) from the generated invariant kernels (p, c and their derivatives in (phi, div u, ||S||), no
    derivative written by hand) through the closed form proved in :func:`checks`.
    """
    from icidr_pde.rheology import INVARIANTS  # noqa: PLC0415

    F0, G0, R0 = (np.asarray(a, float) for a in states)
    lodes = np.deg2rad(np.asarray(GRID_3D["lode_deg"]))
    F, lode = (np.repeat(F0, lodes.size), np.tile(lodes, F0.size))
    G, R = np.repeat(G0, lodes.size), np.repeat(R0, lodes.size)
    s = G / 2
    div = R * s
    k = rheology.kernels(INVARIANTS)
    prm = rheology.material.params
    n = sphere_directions(GRID_3D["directions"])
    with np.errstate(all="ignore"):
        _, c = k.stress_numpy(F, div, s, prm)
        J = np.array(k.stress_jacobian_numpy(F, div, s, prm)).reshape(2, 3, -1)
        Gam = invariant_gamma(np.broadcast_to(c, F.shape), J[0, 1], J[0, 2], J[1, 1], J[1, 2], s,
                              deviator_of_shape(s, lode), n, F)
        bad_state = ~np.all(np.isfinite(Gam.reshape(F.size, -1)), axis=1)
        Gam[bad_state] = 0.0
        lam = np.linalg.eigvals(-Gam).real.max(axis=-1)               # (states, directions)
    lam[bad_state] = np.nan
    scale = np.abs(Gam).reshape(F.size, -1).max(axis=1)
    top = lam.max(axis=1)
    ill = ~(top < -1e-9 * scale)
    frac = (lam > 1e-9 * scale[:, None]).mean(axis=1)
    i = int(np.argmax(np.where(np.isfinite(top), top, np.inf)))
    j = int(np.nanargmax(lam[i])) if np.isfinite(top[i]) else 0
    return {"well_posed": bool(not ill.any()), "states": int(F.size), "directions": GRID_3D["directions"],
            "note": "the 2-D grid's (phi, gamma-dot = 2||S||, div u/||S||) times deviators S of Lode angle "
                    f"{', '.join(f'{v:g}' for v in GRID_3D['lode_deg'])} deg (0 axisymmetric extension, 30 planar "
                    "shear, 60 axisymmetric compression), n on a Fibonacci lattice of the sphere; 3-D conventions "
                    "S = D - (div u/3) I",
            "max_Lambda_plus": {"phi": float(F[i]), "gamma_dot": float(G[i]), "div_u_over_norm_S": float(R[i]),
                                "lode_deg": float(np.rad2deg(lode[i])), "direction": [float(v) for v in n[j]],
                                "Lambda_plus": float(top[i]), "ill_posed_states": int(ill.sum()),
                                "ill_posed_fraction": float(frac[i]) if np.isfinite(top[i]) else None}}


# --- exact checks -----------------------------------------------------------------------------

def _zero(expr) -> bool:
    """expr == 0 identically: expansion first (most entries), simplify where it does not decide."""
    e = sp.expand(sp.together(expr))
    return e == 0 or sp.simplify(e) == 0


def _check_invariant_form():
    """Generic P, C: the derived 3-D Gamma(e_z) is the closed form (every n by rotation covariance)."""
    Pf, Cf = sp.Function("P"), sp.Function("C")
    gen = plane.InvariantLaw("generic", lambda ph, dv, sn: (Pf(ph, dv, sn), Cf(ph, dv, sn)))
    n = sp.Matrix([0, 0, 1])
    L = sp.Matrix(VELOCITY_GRADIENT)
    a, B = principal_part(stress_tensor(gen, L), L)
    G = plane.acoustic_tensor(B, n) * rho * phi
    al = plane.phi_coupling(a, n) * rho * phi
    Gc, alc = plane.invariant_gamma(Pf, Cf, n, L)
    ok = all(_zero((x - y).doit()) for x, y in zip(list(G) + list(al), list(Gc) + list(alc)))
    return Check("3-D Gamma(n)", "any law sigma = -p(phi, div u, ||S||) I + c(...) S with S = D - (div u/3) I: "
                 "rho phi Gamma(n) = (c/2) I + (c/6) n n^T - n (p_div n + p_s S n/(2||S||))^T + S n (c_div n + "
                 "c_s S n/(2||S||))^T, rho phi alpha(n) = -p_phi n + c_phi S n", EXACT if ok else FAILS,
                 "generic functions P, C of (phi, div u, ||S||), general 3x3 grad u, n = e_z (every n by rotation "
                 "covariance)", section=SECTION)


def _check_planar_reduction():
    """Planar isochoric deformation, n in the x-z plane: 3-D Gamma = 2-D Gamma + c/(6 rho phi) n n^T, v decoupled."""
    from .symbols import M  # noqa: PLC0415

    th = sp.Symbol("theta", real=True)
    n3, n2 = sp.Matrix([sp.cos(th), 0, sp.sin(th)]), plane.direction(th)
    iso = {ux: -wz}                                            # div u = 0
    ok = True
    at = PLANAR | iso
    for name in ("mui", "icidr"):
        a3, B3 = principal_part(stress_tensor(name, M_=M, Psi_=Psi))     # differentiated, then made planar
        a2, B2 = plane.principal_part(plane.stress_tensor(name, M_=M, Psi_=Psi))
        G3 = plane.acoustic_tensor(B3, n3).subs(at)
        G2 = plane.acoustic_tensor(B2, n2).subs(iso)
        al3, al2 = plane.phi_coupling(a3, n3).subs(at), plane.phi_coupling(a2, n2).subs(iso)
        k = plane.kinematics(sp.Matrix(VELOCITY_GRADIENT).subs(at))
        _, c = plane.toolkit_law(name, M, Psi).symbolic_stress(phi, k["div"], k["normS"])
        want = sp.zeros(3, 3)
        block = G2 + c / (6 * rho * phi) * n2 * n2.T
        for i, I3 in enumerate((0, 2)):
            for j, J3 in enumerate((0, 2)):
                want[I3, J3] = block[i, j]
        want[1, 1] = c / (2 * rho * phi)
        diff = list(G3 - want) + [al3[0] - al2[0], al3[1], al3[2] - al2[1]]
        ok &= all(_zero(x) for x in diff)
    return Check("3-D planar", "planar deformation with div u = 0 and n in the x-z plane: the 3-D Gamma(n) is the "
                 "2-D one plus c/(6 rho phi) n n^T on the x-z block, Gamma_yy = c/(2 rho phi) (v decoupled), "
                 "alpha = (alpha_x, 0, alpha_z) of 2-D; for mu(I) and iCIDR", EXACT if ok else FAILS,
                 "3-D stress differentiated in the nine entries of grad u vs the 2-D stress in four, at "
                 "grad u = [[-w_z, 0, u_z], [0, 0, 0], [w_x, 0, w_z]], n = (cos theta, 0, sin theta)", section=SECTION)


def checks() -> list[Check]:
    """Exact checks of the 3-D principal part (see module docstring)."""
    return [_check_invariant_form(), _check_planar_reduction()]


# --- the sphere, drawn ----------------------------------------------------------------------

def plot_sphere(result: SpatialStability, ax=None, resolution=(90, 180)):
    """Lambda_max(n) on the sphere (polar angle from z against azimuth from x), its zero contour, the
    worst direction (star) and the x-z plane (azimuth 0 and 180 deg). Returns the axes."""
    import matplotlib.pyplot as plt  # noqa: PLC0415

    a, B = principal_part_at(result.rheology, result.phi, result.velocity_gradient)
    pol = np.linspace(0, math.pi, resolution[0])
    az = np.linspace(-math.pi, math.pi, resolution[1])
    P, Z = np.meshgrid(pol, az, indexing="ij")
    lam = lambda_max(a, B, unit(P, Z).reshape(-1, 3)).reshape(P.shape)
    if ax is None:
        _, ax = plt.subplots(figsize=(6.4, 3.4))
    span = max(float(np.abs(lam).max()), 1e-300)
    im = ax.pcolormesh(np.rad2deg(Z), np.rad2deg(P), lam, cmap="RdBu_r", vmin=-span, vmax=span, shading="auto")
    ax.contour(np.rad2deg(Z), np.rad2deg(P), lam, levels=[0.0], colors="k", linewidths=1.2)
    n = result.worst_direction
    for sign in (1, -1):
        m = sign * n
        ax.plot(math.degrees(math.atan2(m[1], m[0])), math.degrees(math.acos(max(-1.0, min(1.0, m[2])))), "*",
                color="gold", mec="k", ms=13)
    for x in (-180, 0, 180):
        ax.axvline(x, color="0.4", lw=0.6, ls="--")
    ax.set_xlabel("azimuth from x (deg; 0, ±180: the x-z plane)")
    ax.set_ylabel("polar angle from z (deg)")
    ax.set_title(f"{result.rheology}: ill-posed fraction {result.ill_posed_fraction:.3f} of the sphere", fontsize=9)
    plt.colorbar(im, ax=ax, label=r"$\Lambda_{max}(n)$")
    return ax
