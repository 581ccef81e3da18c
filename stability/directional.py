"""Numbers of the 2-D plane-wave analysis: Lambda_max(theta), ill-posed angles, worst angle.

The coefficients a_ij, B_ijkl of :mod:`stability.plane` (derivatives of the 2-D stress
tensor) are compiled once per law and material laws with ``sympy.lambdify`` (d = rho_* = 1,
the material's M(phi), Psi(phi), default (2.10), (2.13)), then contracted with n = (cos theta, sin theta) in numpy:
Gamma(theta) = B_ijkl n_j n_l, alpha(theta) = a_ij n_j.  Per angle:

* ``lambda_max`` = max Re eig(-Gamma) (the larger root Lambda_+ of (A8) at theta),
  ``lambda_minus`` the other root; ``trace_gamma``, ``det_gamma``;
* ``lambda0_limit`` = phi n.Gamma^-1 alpha, the xi -> oo limit of the bounded third
  (phi) root (-C/B of (A17) at theta = 90 deg).

Over the angles: ``max_lambda`` and ``worst_angle_deg`` (the sampled maximum refined by a
bounded scalar maximisation between its neighbours), ``ill_posed_intervals_deg``
(where lambda_max > 0; sign changes between samples refined by Brent's method; reported
modulo 180 deg inside [0, 180], an interval through 0 = 180 deg split in two).
theta = 90 deg is the 1-D direction e_z: there every number equals that of
:func:`stability.numeric.stability_numbers` for grad u = [[0, u_z], [0, w_z]].
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
import sympy as sp
from scipy.optimize import brentq, minimize_scalar
from icidr_pde.outputs import save_figure

from . import plane, rheologies
from .material import RATE_RANGE, check_phi, check_rheology_name, default_material
from .symbols import Mf, Psif, d, phi, rho

GRADIENT_NAMES = ("u_x", "u_z", "w_x", "w_z")


# --- compiled principal part -------------------------------------------------------------

def _expressions(kind, law, laws, grad_u=plane.VELOCITY_GRADIENT):
    """Sympy expressions of `kind` ('principal': the a_ij then the B_ijkl, row-major; 'stress': sigma_ij) for
    `law` with the material functions of `laws` (parameters as symbols) and d = rho_* = 1, at the symbolic
    velocity gradient `grad_u` (2x2 here; 3x3 for :mod:`stability.spatial`)."""
    sigma = plane.stress_tensor(law, grad_u, material=laws)
    r = range(grad_u.shape[0])
    if kind == "stress":
        exprs = [sigma[i, j] for i in r for j in r]
    else:
        a, B = plane.principal_part(sigma, grad_u)
        exprs = [a[i][j] for i in r for j in r]
        exprs += [B[i][j][k][l] for i in r for j in r for k in r for l in r]
    subs = rheologies.concrete_functions(laws)
    return [(e.subs(subs).doit() if e.has(Mf) or e.has(Psif) else e).subs({d: 1, rho: 1}) for e in exprs]


@lru_cache(maxsize=64)
def _lambdified(kind, law, laws, grad_u=sp.ImmutableMatrix(plane.VELOCITY_GRADIENT)):
    exprs = _expressions(kind, law, laws, grad_u)
    params = rheologies.parameter_symbols(laws)
    args = (phi, *grad_u)
    extra = set().union(*(e.free_symbols for e in exprs)) - set(args) - set(params)
    if extra:
        raise ValueError(f"`rheology` {plane.law_name(law)!r}: its stress depends on {sorted(map(str, extra))}, "
                         f"which are neither state variables {[str(s) for s in args]} nor parameters "
                         f"{[str(s) for s in params]} of the material")
    return sp.lambdify((*args, *params), exprs, modules="numpy", cse=True)


def compiled(kind, law, material=None, grad_u=plane.VELOCITY_GRADIENT):
    """(f, params): f(phi, *grad_u (row-major), *params) evaluates :func:`_expressions` (numpy, complex allowed);
    in 2-D f(phi, u_x, u_z, w_x, w_z, *params).

    Compiled once per law, pair of material laws and symbolic gradient (the values enter as
    arguments); a Rheology instance brings its own material when `material` is None.
    """
    from icidr_pde.rheology import Rheology  # noqa: PLC0415

    if material is None and isinstance(law, Rheology):
        material = law.material
    material = default_material(material)
    laws = rheologies._law_representative(material)
    grad_u = sp.ImmutableMatrix(grad_u)
    try:
        f = _lambdified(kind, law, laws, grad_u)
    except TypeError:                                # unhashable user law: compile without the cache
        f = _lambdified.__wrapped__(kind, law, laws, grad_u)
    return f, material.params


def principal_part(rheology, phi0, velocity_gradient, material=None):
    """Numeric a (2, 2) and B (2, 2, 2, 2) of :func:`stability.plane.principal_part` at one state.

    `rheology`: 'mui', 'icidr', or any law accepted by :func:`stability.plane.resolve_law`.
    `velocity_gradient` = (u_x, u_z, w_x, w_z), i.e. grad u = [[u_x, u_z], [w_x, w_z]].
    Raises ValueError for phi outside (0, phi_c), a bad gradient, or a state where the law
    is not differentiable (non-finite coefficients, e.g. mu(I) at ||S|| = 0).
    """
    law = _law(rheology)
    phi0 = float(check_phi(phi0, material))
    L = check_gradient(velocity_gradient)
    f, params = compiled("principal", law, material)
    with np.errstate(all="ignore"):
        vals = np.array(f(phi0, *L, *params), dtype=float)
    if not np.all(np.isfinite(vals)):
        raise ValueError(f"`velocity_gradient` = {list(L)}: the stress of {plane.law_name(law)!r} is not "
                         f"differentiable there (||S|| = {strain_rate_norm(L):g}); choose a state where it is")
    return vals[:4].reshape(2, 2), vals[4:].reshape(2, 2, 2, 2)


def lambda_max_field(rheology, phi_f, grad_u, angles_deg=None, material=None):
    """max over angles of Lambda_max(theta) and the worst angle, point by point on fields (a 2-D tracker's view).

    `phi_f` (...) and `grad_u` (2, 2, ...) with grad_u[i, j] = d_j u_i; angles default 0, 1, ..., 179 deg.
    Points where the law is not differentiable (e.g. mu(I) at ||S|| = 0) or degenerate give nan.
    Returns (lambda_max (...), worst_angle_deg (...)).
    """
    law = _law(rheology)
    phi_f = check_phi(phi_f, material)
    grad_u = np.asarray(grad_u, dtype=float)
    if grad_u.shape[:2] != (2, 2) or not np.all(np.isfinite(grad_u)):
        raise ValueError(f"`grad_u` must be finite with shape (2, 2, ...); got shape {grad_u.shape}")
    angles = np.arange(0.0, 180.0, 1.0) if angles_deg is None else check_angles(angles_deg)
    shape = np.broadcast(phi_f, grad_u[0, 0]).shape
    f, params = compiled("principal", law, material)
    with np.errstate(all="ignore"):
        vals = [np.broadcast_to(np.asarray(v, dtype=float), shape).ravel()
                for v in f(phi_f, grad_u[0, 0], grad_u[0, 1], grad_u[1, 0], grad_u[1, 1], *params)]
    B = np.stack(vals[4:], -1).reshape(-1, 2, 2, 2, 2)
    n = directions(angles)
    G = np.einsum("pijkl,aj,al->paik", B, n, n)
    tr = G[..., 0, 0] + G[..., 1, 1]
    det = G[..., 0, 0] * G[..., 1, 1] - G[..., 0, 1] * G[..., 1, 0]
    with np.errstate(all="ignore"):
        lam = ((-tr + np.sqrt((tr * tr - 4 * det).astype(complex))) / 2).real
        bad = ~np.isfinite(lam).all(axis=1) | (np.abs(G).reshape(G.shape[0], -1).max(axis=1) == 0)
    lam[bad] = np.nan
    i = np.argmax(np.where(np.isnan(lam), -np.inf, lam), axis=1)
    top = lam[np.arange(lam.shape[0]), i]
    worst = np.where(bad, np.nan, angles[i] % 180.0)
    return top.reshape(shape), worst.reshape(shape)


def _law(rheology):
    """A registered name (validated) or Rheology as is; anything else through :func:`stability.plane.resolve_law`."""
    from icidr_pde.rheology import Rheology  # noqa: PLC0415

    if isinstance(rheology, str):
        check_rheology_name(rheology)
        return rheology
    return rheology if isinstance(rheology, Rheology) else plane.resolve_law(rheology)


def check_gradient(velocity_gradient) -> tuple:
    """Validate (u_x, u_z, w_x, w_z): four finite numbers, not all zero."""
    try:
        L = tuple(float(v) for v in velocity_gradient)
    except (TypeError, ValueError):
        raise ValueError(f"`velocity_gradient` must be four numbers (u_x, u_z, w_x, w_z); got "
                         f"{velocity_gradient!r}") from None
    low, high = RATE_RANGE
    if len(L) != 4 or not all(math.isfinite(v) and (v == 0 or low <= abs(v) <= high) for v in L):
        raise ValueError(f"`velocity_gradient` must be four numbers (u_x, u_z, w_x, w_z), each 0 or of "
                         f"magnitude in [{low:g}, {high:g}]; got {velocity_gradient!r}")
    if all(v == 0 for v in L):
        raise ValueError("`velocity_gradient` must not be zero: at zero strain rate Gamma = 0 and the system is "
                         "degenerate; got (0, 0, 0, 0)")
    return L


def strain_rate_norm(L) -> float:
    """||S|| of grad u = [[u_x, u_z], [w_x, w_z]]."""
    ux, uz, wx, wz = L
    return 0.5 * math.hypot(ux - wz, uz + wx)


def directions(angles_deg):
    """Unit vectors n = (cos theta, sin theta), shape (len, 2)."""
    th = np.deg2rad(np.asarray(angles_deg, dtype=float))
    return np.stack([np.cos(th), np.sin(th)], axis=-1)


def gamma_alpha(a, B, angles_deg):
    """Gamma(theta) (k, 2, 2) and alpha(theta) (k, 2) for the angles (degrees)."""
    n = directions(np.atleast_1d(angles_deg))
    return np.einsum("ijkl,aj,al->aik", B, n, n), np.einsum("ij,aj->ai", a, n)


def symbol_matrix(a, B, phi0, xi, angle_deg):
    """A(xi, n) of :func:`stability.plane.symbol_matrix` (numeric, one angle)."""
    G, al = gamma_alpha(a, B, [angle_deg])
    n = directions([angle_deg])[0]
    A = np.zeros((3, 3), dtype=complex)
    A[0, 1:] = -1j * xi * phi0 * n
    A[1:, 0] = 1j * xi * al[0]
    A[1:, 1:] = -xi**2 * G[0]
    return A


def roots(G):
    """Lambda_pm = eigenvalues of -Gamma ((A9)), larger real part first; arrays over the leading axis."""
    tr = np.trace(G, axis1=-2, axis2=-1)
    det = np.linalg.det(G)
    r = np.sqrt((tr * tr - 4 * det).astype(complex))
    lp, lm = (-tr + r) / 2, (-tr - r) / 2
    swap = lp.real < lm.real
    lp[swap], lm[swap] = lm[swap], lp[swap]
    return lp, lm, tr, det


def third_root_limit(G, alpha, n, phi0):
    """phi0 n.Gamma^-1 alpha (the xi -> oo limit of the third root) through the adjugate; inf where det Gamma = 0."""
    adj = np.stack([np.stack([G[:, 1, 1], -G[:, 0, 1]], -1), np.stack([-G[:, 1, 0], G[:, 0, 0]], -1)], -2)
    with np.errstate(divide="ignore", invalid="ignore"):
        return phi0 * np.einsum("ai,aij,aj->a", n, adj, alpha) / np.linalg.det(G)


# --- the analysis ----------------------------------------------------------------------

@dataclass
class DirectionalStability:
    """Plane-wave numbers of one law at one uniform state, over a set of angles (degrees)."""

    rheology: str
    phi: float
    velocity_gradient: tuple
    angles_deg: np.ndarray
    lambda_max: np.ndarray
    lambda_minus: np.ndarray
    trace_gamma: np.ndarray
    det_gamma: np.ndarray
    lambda0_limit: np.ndarray
    max_lambda: float
    worst_angle_deg: float
    ill_posed_intervals_deg: list
    at_90_deg: dict = field(default_factory=dict)

    @property
    def well_posed(self) -> bool:
        """True if no sampled angle has lambda_max > 0 (beyond round-off: 1e-12 max|Gamma|)."""
        return not self.ill_posed_intervals_deg

    def to_json(self) -> dict:
        def num(x):
            x = complex(x)
            if not (math.isfinite(x.real) and math.isfinite(x.imag)):
                return None
            return x.real if abs(x.imag) <= 1e-14 * max(1.0, abs(x)) else {"re": x.real, "im": x.imag}

        return {
            "rheology": self.rheology, "phi": self.phi,
            "velocity_gradient": dict(zip(GRADIENT_NAMES, self.velocity_gradient)),
            "angles_deg": [float(t) for t in self.angles_deg],
            "lambda_max": [float(v) for v in self.lambda_max],
            "max_lambda": self.max_lambda, "worst_angle_deg": self.worst_angle_deg,
            "ill_posed_intervals_deg": [[float(a), float(b)] for a, b in self.ill_posed_intervals_deg],
            "well_posed": self.well_posed,
            "per_angle": {"lambda_minus": [num(v) for v in self.lambda_minus],
                          "trace_gamma": [float(v) for v in self.trace_gamma],
                          "det_gamma": [float(v) for v in self.det_gamma],
                          "lambda0_limit": [num(v) for v in self.lambda0_limit]},
            "at_90_deg": {k: num(v) for k, v in self.at_90_deg.items()},
        }


def lambda_max_function(a, B):
    """theta (degrees, scalar or array) -> max Re eig(-Gamma(theta))."""
    def f(angles_deg):
        G, _ = gamma_alpha(a, B, angles_deg)
        return roots(G)[0].real
    return f


def directional_stability(rheology, phi0, velocity_gradient, angles_deg=None, material=None,
                          xi=1e4) -> DirectionalStability:
    """Plane-wave analysis of `rheology` at (phi0, grad u) over `angles_deg` (default 0, 1, ..., 179).

    Returns a :class:`DirectionalStability`; ``at_90_deg`` holds the 1-D numbers (trace and
    det of Gamma, Lambda_pm, max Re eig A(xi)/xi^2 at `xi`, lambda0 limit) computed by the
    2-D analysis at theta = 90 deg.  Raises ValueError (naming the parameter) on bad input
    and for a degenerate state (Gamma = 0 at every angle).
    """
    angles = np.arange(0.0, 180.0, 1.0) if angles_deg is None else check_angles(angles_deg)
    a, B = principal_part(rheology, phi0, velocity_gradient, material)
    phi0 = float(phi0)
    G, al = gamma_alpha(a, B, angles)
    lp, lm, tr, det = roots(G)
    scale = float(np.abs(G).max())
    if scale == 0.0:
        raise ValueError(f"`velocity_gradient` = {list(velocity_gradient)}: Gamma = 0 at every angle (degenerate "
                         "state, e.g. iCIDR with ||S|| = 0 and div u >= 0, where p = 0 by (4.13))")
    lam0 = third_root_limit(G, al, directions(angles), phi0)
    f = lambda_max_function(a, B)
    worst, best = _refine_max(f, angles, lp.real, tol=1e-12 * scale)
    intervals = _ill_posed_intervals(f, angles, lp.real, tol=1e-12 * scale)
    return DirectionalStability(plane.law_name(rheology), phi0, tuple(float(v) for v in velocity_gradient), angles,
                                lp.real, lm, tr, det, lam0, best, worst, intervals,
                                at_90_deg=numbers_at(a, B, phi0, 90.0, xi))


def numbers_at(a, B, phi0, angle_deg, xi=1e4) -> dict:
    """The 1-D numbers at one angle: trace/det Gamma, Lambda_pm, max Re eig A(xi)/xi^2, lambda0 limit."""
    G, al = gamma_alpha(a, B, [angle_deg])
    lp, lm, tr, det = roots(G)
    lam0 = third_root_limit(G, al, directions([angle_deg]), phi0)[0]
    ev = np.linalg.eigvals(symbol_matrix(a, B, phi0, xi, angle_deg))
    return {"trace_gamma": float(tr[0]), "det_gamma": float(det[0]), "lambda_plus": complex(lp[0]),
            "lambda_minus": complex(lm[0]), "max_re_eig_over_xi2": float(ev.real.max() / xi**2),
            "lambda0_limit": float(lam0)}


def random_states(n=200, seed=0, phi_range=(0.5, 0.815), scale_range=(1e-3, 10.0)):
    """`n` random uniform states (phi, (u_x, u_z, w_x, w_z)): phi uniform in `phi_range`, the gradient a normal
    4-vector times a log-uniform scale (shear, dilation, compression and rotation in every mix)."""
    rng = np.random.default_rng(seed)
    lo, hi = np.log10(scale_range)
    return [(float(rng.uniform(*phi_range)), tuple(float(v) for v in rng.normal(size=4) * 10 ** rng.uniform(lo, hi)))
            for _ in range(n)]


def scan(rheology, states=None, angles_deg=None, material=None) -> dict:
    """Directional verdict over many states (default :func:`random_states`): the sampled check of well-posedness
    for a law where no closed form is known.

    Returns {"n_states", "n_ill_posed", "max_lambda" (over all states and angles), "worst": {"phi",
    "velocity_gradient", "angle_deg", "lambda_max"}, "ill_posed_states": [(phi, grad u), ...]}.
    """
    states = random_states() if states is None else states
    out = {"n_states": 0, "n_ill_posed": 0, "max_lambda": -np.inf, "worst": None, "ill_posed_states": []}
    for phi0, L in states:
        r = directional_stability(rheology, phi0, L, angles_deg, material)
        out["n_states"] += 1
        if not r.well_posed:
            out["n_ill_posed"] += 1
            out["ill_posed_states"].append((phi0, tuple(L)))
        if r.max_lambda > out["max_lambda"]:
            out["max_lambda"] = r.max_lambda
            out["worst"] = {"phi": phi0, "velocity_gradient": tuple(L), "angle_deg": r.worst_angle_deg,
                            "lambda_max": r.max_lambda}
    return out


# --- angles, maximum, intervals -------------------------------------------------------------

#: samples of --angles: one 3 x 3 eigenproblem each, and their arrays; the bound keeps a
#: mistyped step from taking the machine's memory (the cost, measured: docs/plane_waves.md)
MAX_ANGLES = 1_000_001


def parse_angles(text: str) -> np.ndarray:
    """'start:stop:step' in degrees -> start, start + step, ... <= stop; a sample at start + 180 is dropped
    (the same direction: Gamma(theta + 180) = Gamma(theta))."""
    parts = str(text).split(":")
    try:
        start, stop, step = (float(x) for x in parts)
    except ValueError:
        raise ValueError(f"`angles` must be START:STOP:STEP in degrees (e.g. 0:180:1); got {text!r}") from None
    if not all(math.isfinite(v) for v in (start, stop, step)) or step <= 0 or stop < start:
        raise ValueError(f"`angles` needs finite START <= STOP and STEP > 0 (degrees); got {text!r}")
    stop = min(stop, start + 180.0)  # the samples beyond are dropped below
    k = int(math.floor((stop - start) / step + 1e-9))
    if k + 1 > MAX_ANGLES:
        raise ValueError(f"`angles` must give at most {MAX_ANGLES} samples in a half turn (STEP >= "
                         f"{180.0 / (MAX_ANGLES - 1):g} deg); got {text!r} ({k + 1} samples)")
    ang = start + step * np.arange(k + 1)
    return check_angles(ang[ang < start + 180.0 - 1e-9])


def check_angles(angles_deg) -> np.ndarray:
    """Validate sample angles (degrees): finite, strictly increasing, spanning less than 180 deg."""
    ang = np.atleast_1d(np.asarray(angles_deg, dtype=float))
    if ang.size == 0 or not np.all(np.isfinite(ang)) or np.any(np.diff(ang) <= 0) or ang[-1] - ang[0] >= 180.0:
        raise ValueError("`angles` must be finite, strictly increasing degrees spanning less than 180 (theta and "
                         f"theta + 180 are the same direction); got {angles_deg!r}")
    return ang


def _periodic(angles) -> bool:
    """True if the samples close the circle: the gap from the last to the first + 180 deg is no wider than the
    widest step between samples (so no sign change can hide there beyond what the sampling resolves anyway)."""
    if angles.size < 3:
        return False
    return bool(angles[0] + 180.0 - angles[-1] <= np.diff(angles).max() * (1 + 1e-9))


def _neighbours(angles, i):
    per = _periodic(angles)
    lo = angles[i - 1] if i > 0 else (angles[-1] - 180.0 if per else angles[0])
    hi = angles[i + 1] if i + 1 < angles.size else (angles[0] + 180.0 if per else angles[-1])
    return lo, hi


def _refine_max(f, angles, values, tol=0.0):
    """(worst angle in [0, 180), max): the best sample refined between its neighbours.

    Samples within `tol` of the maximum count as ties (the first is taken), and a flat
    neighbourhood is not refined: an isotropic lambda_max (iCIDR) reports the first angle.
    """
    top = float(np.max(values))
    i = int(np.flatnonzero(values >= top - tol)[0])
    best_t, best_v = float(angles[i]), float(values[i])
    lo, hi = _neighbours(angles, i)
    flat = np.ptp(f(np.array([lo, best_t, hi]))) <= tol
    if hi > lo and not flat:
        res = minimize_scalar(lambda t: -float(f(t)[0]), bounds=(lo, hi), method="bounded",
                              options={"xatol": 1e-10})
        if -res.fun > best_v + 1e-13 * max(1.0, abs(best_v)):
            best_t, best_v = float(res.x), float(-res.fun)
    return best_t % 180.0, best_v


def _ill_posed_intervals(f, angles, values, tol):
    """Intervals (degrees, modulo 180 within [0, 180]) where f > tol, endpoints refined by brentq."""
    per = _periodic(angles)
    pos = values > tol
    if not pos.any():
        return []
    if pos.all():
        return [[0.0, 180.0]] if per else _mod180([[float(angles[0]), float(angles[-1])]])
    t = list(angles) + ([angles[0] + 180.0] if per else [])
    v = list(values) + ([values[0]] if per else [])
    p = [x > tol for x in v]
    g = lambda x: float(f(x)[0])  # noqa: E731  (endpoints: the zeros of lambda_max itself)
    cross = []                                   # (angle, entering?) at every sign change
    for k in range(len(t) - 1):
        if p[k] != p[k + 1]:
            ga, gb = g(t[k]), g(t[k + 1])
            x = brentq(g, t[k], t[k + 1], xtol=1e-12) if ga * gb < 0 else (t[k] if p[k + 1] else t[k + 1])
            cross.append((x, p[k + 1]))
    out = []
    if per:
        # rotate so that the list starts with an entry into the ill-posed set
        j = next(i for i, (_, enter) in enumerate(cross) if enter)
        cross = cross[j:] + [(x + 180.0, e) for x, e in cross[:j]]
        for (x0, _), (x1, _) in zip(cross[::2], cross[1::2]):
            out.append([x0, x1])
    else:
        start = float(t[0]) if p[0] else None
        for x, enter in cross:
            if enter:
                start = x
            else:
                out.append([start, x])
                start = None
        if start is not None:
            out.append([start, float(t[-1])])
    return _mod180(out)


def _mod180(intervals):
    """Map intervals to [0, 180], splitting one that passes through 0 = 180 deg; sorted."""
    out = []
    for a, b in intervals:
        a0 = a % 180.0
        b0 = a0 + (b - a)
        if b0 > 180.0 + 1e-12:
            out += [[a0, 180.0], [0.0, b0 - 180.0]]
        else:
            out.append([a0, min(b0, 180.0)])
    return sorted(out)


# --- polar plot -----------------------------------------------------------------------------

def one_d_lambda_plus(result: DirectionalStability, material=None):
    """Lambda_+ of the 1-D toolkit (:func:`stability.numeric.stability_numbers`) if grad u has the 1-D form."""
    ux, uz, wx, wz = result.velocity_gradient
    if ux != 0 or wx != 0 or result.rheology not in ("mui", "icidr"):
        return None
    from .numeric import stability_numbers  # noqa: PLC0415
    return float(stability_numbers(result.rheology, result.phi, uz, wz, material=material).lambda_plus.real)


_STYLE = {"mui": ("C3", r"$\mu(I),\Phi(I)$"), "icidr": ("C0", "iCIDR")}


def plot_polar(results, ax=None, title=None, material=None):
    """Polar plot of lambda_max(theta) (radius, may be negative: the dashed circle is 0) for each result.

    theta runs over [0, 360) (Gamma(theta + 180) = Gamma(theta)); ill-posed angles are shaded;
    the 1-D value Lambda_+ (theta = 90 deg, from the 1-D toolkit when grad u has the 1-D form)
    is marked with a star.  Returns the axes.
    """
    import matplotlib.pyplot as plt  # noqa: PLC0415

    if ax is None:
        _, ax = plt.subplots(subplot_kw={"projection": "polar"}, figsize=(5, 5))
    lo = min(float(np.min(r.lambda_max)) for r in results)
    hi = max(float(np.max(r.lambda_max)) for r in results)
    span = max(hi - lo, 1e-12)
    rmin, rmax = min(lo, 0.0) - 0.15 * span, max(hi, 0.0) + 0.1 * span
    full = np.linspace(0, 2 * np.pi, 721)
    ax.plot(full, np.zeros_like(full), "k--", lw=0.8, label=r"$\Lambda = 0$")
    for k, r in enumerate(results):
        color, label = _STYLE.get(r.rheology, (f"C{k + 2}", r.rheology))
        th = np.deg2rad(np.concatenate([r.angles_deg, r.angles_deg + 180.0, r.angles_deg[:1] + 360.0]))
        lam = np.concatenate([r.lambda_max, r.lambda_max, r.lambda_max[:1]])
        ax.plot(th, lam, color=color, lw=1.8, label=label + r" $\Lambda_{max}(\theta)$")
        for a, b in r.ill_posed_intervals_deg:
            for off in (0.0, 180.0):
                ax.fill_between(np.deg2rad(np.linspace(a, b, 50) + off), rmin, rmax, color=color, alpha=0.12, lw=0)
        lp = one_d_lambda_plus(r, material)
        lp = float(r.at_90_deg["lambda_plus"].real) if lp is None else lp
        ax.plot(np.deg2rad([90.0, 270.0]), [lp, lp], "*", color=color, ms=12, mec="k",
                label=rf"1-D $\Lambda_+$ ($\theta$ = 90°) = {lp:.4g}")
    ax.set_rlim(rmin, rmax)
    ax.set_thetagrids(range(0, 360, 30))
    ax.tick_params(labelsize=7)
    if title:
        ax.set_title(title, fontsize=9)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.06), ncol=2, fontsize=7)
    return ax


def save_polar(results, path, title=None, material=None):
    """Write :func:`plot_polar` of `results` to the PNG `path` (whole or not at all: :mod:`icidr_pde.outputs`)."""
    import matplotlib  # noqa: PLC0415
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    fig, ax = plt.subplots(subplot_kw={"projection": "polar"}, figsize=(5.2, 6.2))
    plot_polar(results, ax, title, material)
    fig.tight_layout()
    try:
        save_figure(fig, path, dpi=120)
    finally:
        plt.close(fig)
    return path
