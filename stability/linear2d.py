"""Linearized 2-D continuum problem of the shear cell about an x-independent base state.

The 2-D equations (2.1)-(2.2), with the corrected index form of (2.2) (``div sigma``,
``(d_j sigma_ij)``), non-dimensional (3.12) (d = rho_* = V0 = 1), gravity-free, as the 2-D cell
``fv2d`` integrates them (:mod:`icidr_pde.cells.plane2d.pde`):

    phi_t = -d_x(phi u) - d_z(phi w),                                          (2.1)
    u_t   = (d_x sigma_xx + d_z sigma_xz)/phi - u u_x - w u_z,                 (2.2)
    w_t   = (d_x sigma_xz + d_z sigma_zz)/phi - u w_x - w w_z,                 (2.2)

    sigma = -p I + tau,  tau = c S   ((2.3), alignment (2.6)),

with (p, tau_xx, tau_xz, tau_zz) the law's stress at (phi, u_x, u_z, w_x, w_z): the generated
plane-flow kernel of :meth:`icidr_pde.rheology.Rheology.kernels` (``PLANE_FLOW``) -- the very
functions and exact partial derivatives the 2-D cell evaluates on its faces, generated from the
law's one sympy definition (:meth:`~icidr_pde.rheology.Rheology.law`: (2.14)/(2.6)-(2.7) for
'mui', (4.12)/(4.14) for 'icidr'; an implicit equation of state is differentiated by the implicit
function theorem there), the same definition as :func:`stability.plane.stress_tensor`. No
coefficient is typed in here.

**Base state.** phi0(z), u0(z), w0(z) on 0 <= z <= H (:class:`BaseState`): uniform simple shear
(:func:`simple_shear`), or the x-average of a 2-D snapshot (:func:`from_snapshot`): the cell-centre
values with the walls' values of the cell's ghost maps
(:func:`icidr_pde.discretizations.core.ghost_coefficients`: u = 0 at z = 0, u = V0 at z = H,
w = 0 on both, phi of zero gradient), joined by a cubic spline that gives the z-derivatives. The
base need not be steady: what is linearized is the right-hand side at that instant (the frozen
base, its own rate dropped).

**Linearization** (full, not only the principal part). With f = f0(z) + f^(z) exp(i kappa x),
kappa = 2 pi k / L (k wavelengths in the period L), and q = (phi, u_x, u_z, w_x, w_z):

    sigma'_ij = sum_q (d sigma_ij/d q)(base) q',   q' = (phi^, i kappa u^, D u^, i kappa w^, D w^),
    phi^_t = -i kappa (phi0 u^ + u0 phi^) - D(phi0 w^ + w0 phi^),
    u^_t   = (i kappa sigma'_xx + D sigma'_xz)/phi0 - (D sigma0_xz/phi0^2) phi^
             - (i kappa u0 + w0 D) u^ - u0' w^,
    w^_t   = (i kappa sigma'_xz + D sigma'_zz)/phi0 - (D sigma0_zz/phi0^2) phi^
             - (i kappa u0 + w0 D) w^ - w0' w^,

D = d/dz: advection by the base flow, the base's z-variation (the coefficients d sigma/d q vary
with z and stand inside D) and the base stress divergence all kept. D sigma0 is the chain rule
sum_q (d sigma/d q) dq0/dz along the base (its derivatives from the spline).

**Walls** (3.9), as the cell imposes them: u and w are Dirichlet (ghost = 2 value - edge), so
u^ = w^ = 0 at z = 0 and z = H. phi takes no condition in the continuum problem (first order,
transported by w0 = 0 at the walls; the cell's zero-gradient ghost only supplies phi's face value
in the wall mass flux phi w, which vanishes with w).

**Discretization.** Chebyshev collocation at the n Gauss-Lobatto points of [0, H]
(:mod:`icidr_pde.discretizations.chebyshev`), unknowns (phi^, u^, w^) at every point. The wall
rows of u^, w^ are the boundary conditions: either the pencil (A, B) with those rows
``u^ = 0`` in A and zero in B (``method='generalized'``, :func:`scipy.linalg.eig` of a singular B;
its infinite eigenvalues are dropped), or the same problem with the wall unknowns eliminated
(``method='reduced'``, the default; the same finite eigenvalues). :meth:`Linear2D.rate` is
max Re lambda.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import scipy.linalg
from scipy.interpolate import CubicSpline

from icidr_pde.discretizations.chebyshev import cgl_nodes, diff_matrix
from icidr_pde.discretizations.core import ghost_coefficients
from icidr_pde.rheology import PLANE_FLOW, Rheology, get_rheology

__all__ = ["BaseState", "simple_shear", "from_cells", "from_snapshot", "Linear2D", "growth_rates",
           "wall_conditions"]

FIELDS = ("phi", "u", "w")
#: the law's inputs, in the order of the plane-flow kernel's Jacobian
INPUTS = ("phi", "u_x", "u_z", "w_x", "w_z")
#: the plane-flow kernel's outputs
OUTPUTS = ("p", "tau_xx", "tau_xz", "tau_zz")


# --- base state -------------------------------------------------------------------------------

@dataclass(frozen=True)
class BaseState:
    """An x-independent state on 0 <= z <= H: ``phi(z, nu)``, ``u(z, nu)``, ``w(z, nu)`` give the
    nu-th z-derivative (nu = 0, 1, 2) of each field; `V0` is the top wall's velocity."""

    H: float
    V0: float
    phi: Callable
    u: Callable
    w: Callable
    label: str = ""

    def fields(self, z, nu: int = 0) -> np.ndarray:
        """(3, len(z)) nu-th derivatives of (phi, u, w) at z."""
        z = np.asarray(z, float)
        return np.array([np.broadcast_to(np.asarray(f(z, nu), float), z.shape) for f in (self.phi, self.u, self.w)])


def _polynomial(coefficients):
    p = np.polynomial.Polynomial(coefficients)
    return lambda z, nu=0: p.deriv(nu)(np.asarray(z, float)) if nu else p(np.asarray(z, float))


def simple_shear(phi0: float = 0.78, H: float = 30.0, V0: float = 1.0) -> BaseState:
    """Uniform simple shear: phi = phi0, u = V0 z/H, w = 0 (the steady state of the cell, bump2d's start)."""
    return BaseState(float(H), float(V0), _polynomial([phi0]), _polynomial([0.0, V0 / H]), _polynomial([0.0]),
                     label=f"simple shear phi0 = {phi0:g}")


def wall_conditions(V0: float = 1.0) -> dict:
    """The walls of the 2-D cell from its ghost maps (:func:`~icidr_pde.discretizations.core.ghost_coefficients`):
    {field: ('value', (value at z = 0, value at z = H)) or ('gradient', None)}. Raises if a map is neither
    Dirichlet (ghost = 2 value - edge) nor zero gradient (ghost = edge): this module would not know it."""
    g = ghost_coefficients(V0)
    out = {}
    for k, name in enumerate(FIELDS):
        alpha, beta = g[k, :, 0], g[k, :, 1]
        if np.all(alpha == -1.0):
            out[name] = ("value", tuple(float(b) / 2 for b in beta))
        elif np.all(alpha == 1.0) and np.all(beta == 0.0):
            out[name] = ("gradient", None)
        else:
            raise ValueError(f"wall map of {name!r} is neither Dirichlet nor zero gradient: {g[k].tolist()}")
    return out


def from_cells(phi, u, w, H: float = 30.0, V0: float = 1.0, label: str = "") -> BaseState:
    """Base state from cell-centre profiles (Nz,) at z_j = (j + 1/2) H/Nz, as the 2-D cell stores them.

    The walls' values are the cell's (:func:`wall_conditions`: the mean of the edge and ghost values,
    i.e. the Dirichlet value of u and w, the edge value of phi); a not-a-knot cubic spline through
    the walls and centres gives the fields and their z-derivatives.
    """
    cols = [np.asarray(a, float) for a in (phi, u, w)]
    nz = cols[0].size
    if any(c.shape != (nz,) for c in cols) or nz < 4:
        raise ValueError("`phi`, `u`, `w` must be profiles of the same length >= 4")
    zc = (np.arange(nz) + 0.5) * H / nz
    z = np.concatenate(([0.0], zc, [H]))
    g = ghost_coefficients(V0)
    splines = []
    for k, c in enumerate(cols):
        lo = 0.5 * ((1 + g[k, 0, 0]) * c[0] + g[k, 0, 1])
        hi = 0.5 * ((1 + g[k, 1, 0]) * c[-1] + g[k, 1, 1])
        s = CubicSpline(z, np.concatenate(([lo], c, [hi])))
        splines.append(lambda zz, nu=0, s=s: s(zz, nu))
    return BaseState(float(H), float(V0), *splines, label=label or f"profiles on {nz} cells")


def from_snapshot(data, H: float = 30.0, V0: float = 1.0, label: str = "") -> BaseState:
    """Base state from a 2-D snapshot (3, Nx, Nz) of (phi, u, w): the x-averages, through :func:`from_cells`."""
    data = np.asarray(data, float)
    if data.ndim != 3 or data.shape[0] != 3:
        raise ValueError(f"`data` must have shape (3, Nx, Nz); got {data.shape}")
    return from_cells(*data.mean(axis=1), H=H, V0=V0, label=label or "x-average of a snapshot")


# --- the linear operator -----------------------------------------------------------------------

class Linear2D:
    """The collocated linear operator of the module docstring for one law, base state, period L and n points.

    Args:
        rheology: a registered name ('icidr', 'mui', ...) or Rheology instance
        base: :class:`BaseState`
        L: the period in x (the box length)
        n: number of Chebyshev-Gauss-Lobatto points in z (walls included)
        material: the law's material (default Table 1), for a name
    """

    def __init__(self, rheology: str | Rheology = "icidr", base: BaseState | None = None, L: float = 30.0,
                 n: int = 64, material=None):
        self.rheology = rheology if isinstance(rheology, Rheology) else get_rheology(rheology, material)
        self.base = simple_shear() if base is None else base
        if int(n) != n or n < 4:
            raise ValueError(f"`n` must be an integer >= 4; got {n}")
        self.n, self.L, self.H = int(n), float(L), self.base.H
        walls = wall_conditions(self.base.V0)
        if walls["u"][0] != "value" or walls["w"][0] != "value":
            raise ValueError("the cell's walls are not Dirichlet for u and w")
        self.z = cgl_nodes(self.n, self.H)
        self.D = diff_matrix(self.n, self.H)
        b0, b1, b2 = (self.base.fields(self.z, nu) for nu in (0, 1, 2))
        self.phi0, self.u0, self.w0 = b0
        self.phi0_z, self.u0_z, self.w0_z = b1
        zero = np.zeros(self.n)
        law, params = self.rheology.kernels(PLANE_FLOW), self.rheology.material.params
        q0 = (self.phi0, zero, self.u0_z, zero, self.w0_z)
        with np.errstate(all="ignore"):
            self.stress0 = np.array(law.stress_numpy(*q0, params), float)                 # (4, n)
            jac = np.array(law.stress_jacobian_numpy(*q0, params), float).reshape(4, 5, self.n)
        if not (np.all(np.isfinite(jac)) and np.all(np.isfinite(self.stress0))):
            raise ValueError(f"the stress of {self.rheology.name!r} is not differentiable on this base state "
                             "(e.g. mu(I) at ||S|| = 0)")
        # sigma_xx = tau_xx - p, sigma_xz = tau_xz, sigma_zz = tau_zz - p, and their derivatives by q
        self.dsigma = {"xx": jac[1] - jac[0], "xz": jac[2], "zz": jac[3] - jac[0]}
        dq0 = np.array([self.phi0_z, zero, b2[1], zero, b2[2]])                          # d q0/dz
        self.div_sigma0 = {"x": np.einsum("qn,qn->n", self.dsigma["xz"], dq0),          # d_z sigma0_xz
                           "z": np.einsum("qn,qn->n", self.dsigma["zz"], dq0)}          # d_z sigma0_zz

    def wavenumber(self, k) -> float:
        """kappa = 2 pi k / L."""
        return 2 * np.pi * float(k) / self.L

    def _stress_rows(self, comp, kappa):
        """sigma'_comp as an operator on (phi^, u^, w^): three (n, n) blocks."""
        c, D = self.dsigma[comp], self.D
        ik = 1j * kappa
        return [np.diag(c[0]).astype(complex),
                np.diag(ik * c[1]) + c[2][:, None] * D,
                np.diag(ik * c[3]) + c[4][:, None] * D]

    def operator(self, k) -> np.ndarray:
        """The (3n, 3n) complex matrix of the linearized right-hand side at x-wave number k (no wall rows imposed)."""
        n, D = self.n, self.D
        kappa = self.wavenumber(k)
        ik = 1j * kappa
        diag = np.diag
        inv_phi = 1.0 / self.phi0
        A = np.zeros((3 * n, 3 * n), complex)
        blk = lambda a, b: (slice(a * n, (a + 1) * n), slice(b * n, (b + 1) * n))  # noqa: E731
        # mass (2.1)
        A[blk(0, 0)] = -ik * diag(self.u0) - D * self.w0[None, :]
        A[blk(0, 1)] = -ik * diag(self.phi0)
        A[blk(0, 2)] = -D * self.phi0[None, :]
        # momentum (2.2)
        sxx, sxz, szz = (self._stress_rows(c, kappa) for c in ("xx", "xz", "zz"))
        adv = ik * diag(self.u0) + self.w0[:, None] * D
        for row, (fx, fz), div0 in ((1, (sxx, sxz), self.div_sigma0["x"]), (2, (sxz, szz), self.div_sigma0["z"])):
            for col in range(3):
                A[blk(row, col)] = inv_phi[:, None] * (ik * fx[col] + D @ fz[col])
            A[blk(row, 0)] -= diag(div0 * inv_phi**2)
            A[blk(row, row)] -= adv
        A[blk(1, 2)] -= diag(self.u0_z)
        A[blk(2, 2)] -= diag(self.w0_z)
        return A

    def wall_rows(self) -> np.ndarray:
        """Indices of the unknowns u^, w^ at z = 0 and z = H (the Dirichlet rows)."""
        n = self.n
        return np.array([n, 2 * n - 1, 2 * n, 3 * n - 1])

    def pencil(self, k) -> tuple[np.ndarray, np.ndarray]:
        """(A, B) of A v = lambda B v: the wall rows of u^, w^ are the conditions u^ = w^ = 0 (rows of the
        identity in A, zero rows in B, so B is singular)."""
        A = self.operator(k)
        B = np.eye(A.shape[0], dtype=complex)
        for r in self.wall_rows():
            A[r, :] = 0.0
            A[r, r] = 1.0
            B[r, r] = 0.0
        return A, B

    def reduced(self, k) -> np.ndarray:
        """The operator on the unknowns left free by the walls (wall values of u^, w^ eliminated as 0)."""
        keep = np.setdiff1d(np.arange(3 * self.n), self.wall_rows())
        return self.operator(k)[np.ix_(keep, keep)]

    def eigenvalues(self, k, method: str = "reduced") -> np.ndarray:
        """The finite eigenvalues at x-wave number k, largest real part first."""
        if method == "reduced":
            lam = scipy.linalg.eigvals(self.reduced(k), overwrite_a=True, check_finite=False)
        elif method == "generalized":
            A, B = self.pencil(k)
            scale = np.abs(A).sum(axis=1).max()        # bounds |lambda| of every finite eigenvalue
            with np.errstate(all="ignore"):
                lam = scipy.linalg.eigvals(A, B, check_finite=False)
            # B's zero rows give infinite eigenvalues (LAPACK may return them as huge, not inf)
            lam = lam[np.isfinite(lam) & (np.abs(lam) < 1e6 * scale)]
        else:
            raise ValueError(f"`method` must be 'reduced' or 'generalized'; got {method!r}")
        return lam[np.argsort(-lam.real)]

    def rate(self, k, method: str = "reduced") -> float:
        """max Re lambda at x-wave number k."""
        return float(self.eigenvalues(k, method)[0].real)

    def apply(self, k, fields) -> np.ndarray:
        """The linearized rates (3, n) of the perturbation amplitudes `fields` (3, n) at the nodes (no walls imposed)."""
        return (self.operator(k) @ np.asarray(fields, complex).reshape(-1)).reshape(3, self.n)


def growth_rates(rheology, base: BaseState, L: float, ks, n: int = 128, material=None,
                 method: str = "reduced") -> np.ndarray:
    """max Re lambda of the linearized 2-D problem at each x-wave number in `ks` (see :class:`Linear2D`)."""
    op = Linear2D(rheology, base, L, n, material)
    return np.array([op.rate(k, method) for k in np.atleast_1d(ks)])
