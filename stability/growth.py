"""Numerical cross-checks of the symbols (issue item 8).

a. :func:`eigen_vs_symbol` -- eigenvalues of A(xi) (A4) at large xi against Lambda_pm xi^2
   (A9) and the third eigenvalue against -C/B.
b. :func:`measured_growth_rate` -- time-integrates the linearised system (A2) for a single
   Fourier mode on a periodic domain (pseudo-spectral in z, DOP853 in t) and measures the
   growth rate of the L2 norm; compared with max Re eig A(xi).
c. :func:`fd_jacobian` / :func:`fd_max_growth` -- the finite-difference operator of the
   nonlinear shear-cell equations on a periodic grid (compact face stencil), linearised
   about a uniform state by complex-step differentiation; its spectrum grows like 1/h^2
   for mu(I),Phi(I) at an ill-posed state and stays bounded for iCIDR.
   :func:`fd_symbol_eigenvalues` is the exact discrete symbol of that scheme.

The frame is that of (A2): momentum divided by rho_* phi, base vertical convection
w0 d_z dropped (frozen coefficients), base strain rates (u_z, w_z) entering the fluxes.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp
from icidr_pde.outputs import save_figure

from . import rheologies
from .material import check_phi, check_rate, check_rheology_name, check_xi, default_material
from .numeric import A_matrix, coefficients, stability_numbers

DEFAULT_STATE = {"phi": 0.78, "uz": 1.0 / 30.0, "wz": 0.05}   # the ill-posed state of fig. 2 / issue item 7


# --- a. eigenvalues of A(xi) vs the large-xi symbols ------------------------------------

def eigen_vs_symbol(name, phi, uz, wz, xis, material=None):
    """For each xi: sorted real parts of eig A(xi)/xi^2 and the symbol values (Lambda_+, Lambda_-, -C/B)."""
    c = coefficients(name, phi, uz, wz, material)
    sn = stability_numbers(name, phi, uz, wz, material=material)
    rows = []
    for xi in xis:
        xi = check_xi(xi)
        ev = np.linalg.eigvals(A_matrix(c, phi, xi))
        ev = ev[np.argsort(-np.abs(ev))]            # two O(xi^2) eigenvalues first, then lambda_0
        big = sorted(ev[:2], key=lambda z: -z.real)
        rows.append({"xi": xi, "lambda_plus": big[0] / xi**2, "lambda_minus": big[1] / xi**2, "lambda0": ev[2]})
    return rows, sn


# --- b. time integration of the linearised PDE for one Fourier mode -------------------

def _mode_projector(N):
    """Mask keeping only the Fourier modes m = +-1 of an N-point periodic grid."""
    m = np.rint(np.fft.fftfreq(N) * N)
    return np.abs(m) == 1


def project_single_mode(y, N):
    """Project each of the three fields of `y` onto the single Fourier mode m = +-1."""
    mask = _mode_projector(N)
    return np.concatenate([np.real(np.fft.ifft(mask * np.fft.fft(y[j * N:(j + 1) * N]))) for j in range(3)])


def linear_rhs_factory(c, phi0, L, N):
    """RHS of (A2) (w0 = 0) on a periodic grid of N points, spectral derivatives.

    Derivatives are computed by FFT and restricted to the modes m = +-1 (the
    single-mode subspace is invariant; without the restriction rounding errors in
    higher modes would grow at the ill-posed rate Lambda_+ (m xi)^2 and swamp the mode).
    """
    k = 2 * np.pi * np.fft.fftfreq(N, d=L / N)
    mask = _mode_projector(N)

    def dz(f, order=1):
        return np.real(np.fft.ifft(mask * (1j * k) ** order * np.fft.fft(f)))

    def rhs(_t, y):
        ph, u, w = y[:N], y[N:2 * N], y[2 * N:]
        ph_z, u_zz, w_z, w_zz = dz(ph), dz(u, 2), dz(w), dz(w, 2)
        return np.concatenate([
            -phi0 * w_z,
            c["a1"] * ph_z + c["b11"] * u_zz + c["b12"] * w_zz,
            c["a2"] * ph_z + c["b21"] * u_zz + c["b22"] * w_zz,
        ])

    return rhs


def measured_growth_rate(name, phi, uz, wz, xi, material=None, n_points=8, seed=0, rtol=1e-12):
    """Growth rate of a single Fourier mode e^{i xi z} measured by integrating (A2) in time.

    Domain length 2 pi/xi (periodic), random real initial amplitudes of cos and sin for
    (phi, u, w).  The L2 norm of a single real mode grows exactly like e^{Re(lambda) t}
    once the dominant eigenvalue has taken over (z-averaging removes the oscillation of
    a complex lambda).  The integration time is chosen from the spectral gap so that the
    other two modes are suppressed by e^{-25}; the state is renormalised periodically.
    Returns dict(measured, predicted) with predicted = max Re eig A(xi).
    """
    xi = check_xi(xi)
    c = coefficients(name, phi, uz, wz, material)
    ev = np.linalg.eigvals(A_matrix(c, phi, xi))
    re = np.sort(ev.real)[::-1]
    predicted = float(re[0])
    gap = float(re[0] - re[1])
    if gap <= 1e-9 * max(1.0, abs(re[0])):
        raise ValueError(f"`xi` = {xi}: dominant eigenvalue is not separated (gap {gap:g}); choose another xi")
    L, N = 2 * np.pi / xi, n_points
    z = np.arange(N) * L / N
    rng = np.random.default_rng(seed)
    amp = rng.normal(size=(3, 2))
    y = np.concatenate([amp[j, 0] * np.cos(xi * z) + amp[j, 1] * np.sin(xi * z) for j in range(3)])
    rhs = linear_rhs_factory(c, phi, L, N)
    # stiff when the most negative mode is much faster than the measured one: implicit Radau
    t_total = 50.0 / gap + 0.5 / max(abs(predicted), 1e-3)
    stiff = abs(float(re[-1])) * t_total > 2e4
    method = "Radau" if stiff else "DOP853"
    jac = np.column_stack([rhs(0.0, e) for e in np.eye(3 * N)]) if stiff else None
    t_settle = 25.0 / gap
    t_measure = max(25.0 / gap, 0.5 / max(abs(predicted), 1e-3))
    chunk = min(t_settle, 10.0 / max(abs(predicted), gap))
    logn, t = 0.0, 0.0
    y = y / np.linalg.norm(y)
    log_at_settle = None
    t_end = t_settle + t_measure
    while t < t_end - 1e-15:
        dt = min(chunk, t_end - t)
        if log_at_settle is None and t + dt > t_settle:
            dt = t_settle - t
        sol = solve_ivp(rhs, (0.0, dt), y, method=method, rtol=rtol, atol=rtol * 1e-3,
                        **({"jac": jac} if stiff else {}))
        y = project_single_mode(sol.y[:, -1], N)
        nrm = np.linalg.norm(y)
        logn += np.log(nrm)
        y = y / nrm
        t += dt
        if log_at_settle is None and abs(t - t_settle) < 1e-12 * max(1.0, t_settle):
            log_at_settle = logn
    measured = (logn - log_at_settle) / t_measure
    return {"xi": xi, "measured": float(measured), "predicted": predicted, "method": method,
            "rel_error": float(abs(measured - predicted) / abs(predicted))}


# --- c. finite-difference operator of the nonlinear equations ----------------------------

def fd_rhs(name, U, uz0, wz0, h, material=None):
    """Semi-discrete RHS of the nonlinear shear-cell equations on a periodic grid.

    U = (phi_j, u'_j, w'_j) (perturbation velocities; base u = uz0 z, w = wz0 z).
    Face values: u_z = uz0 + (u'_{j+1} - u'_j)/h, w_z likewise, phi_f = (phi_j + phi_{j+1})/2;
    fluxes F1 = tau_xz, F2 = tau_zz - p on faces; cells get d_t u = (F_{j+1/2} - F_{j-1/2})/(h phi_j);
    mass in conservative form d_t phi = -(G_{j+1/2} - G_{j-1/2})/h, G = phi_f w'_f, w'_f the face average
    (base convection/dilation frozen out as in (A2)).  Works for complex U (complex-step).
    """
    N = U.shape[0] // 3
    ph, u, w = U[:N], U[N:2 * N], U[2 * N:]
    nxt = lambda f: np.roll(f, -1)  # noqa: E731
    ph_f = 0.5 * (ph + nxt(ph))
    uz_f = uz0 + (nxt(u) - u) / h
    wz_f = wz0 + (nxt(w) - w) / h
    p, txz, tzz = rheologies.compiled_stress(name, material)(ph_f, uz_f, wz_f, *default_material(material).params)
    F1, F2 = txz, tzz - p
    prev = lambda f: np.roll(f, 1)  # noqa: E731
    G = ph_f * 0.5 * (w + nxt(w))
    return np.concatenate([-(G - prev(G)) / h, (F1 - prev(F1)) / (h * ph), (F2 - prev(F2)) / (h * ph)])


def fd_jacobian(name, phi0, uz0, wz0, N, L=30.0, material=None):
    """Jacobian of :func:`fd_rhs` at the uniform state, by complex-step differentiation (exact to rounding)."""
    check_rheology_name(name)
    check_phi(phi0, material, "phi")
    check_rate(uz0, "uz")
    check_rate(wz0, "wz")
    if int(N) != N or N < 4:
        raise ValueError(f"`N` must be an integer >= 4; got {N!r}")
    N = int(N)
    h = L / N
    U0 = np.concatenate([np.full(N, float(phi0)), np.zeros(N), np.zeros(N)]).astype(complex)
    eps = 1e-30
    J = np.empty((3 * N, 3 * N))
    for k in range(3 * N):
        U = U0.copy()
        U[k] += 1j * eps
        J[:, k] = fd_rhs(name, U, uz0, wz0, h, material).imag / eps
    return J


def fd_symbol_eigenvalues(name, phi0, uz0, wz0, N, L=30.0, material=None):
    """Eigenvalues of the exact discrete symbol of the scheme, over the N discrete wavenumbers.

    Second derivatives -> -(2/h)^2 sin^2(kh/2), first derivatives (centred through face
    averages) -> i sin(kh)/h, with the (A2) coefficients from :mod:`stability.numeric`.
    """
    c = coefficients(name, phi0, uz0, wz0, material)
    h = L / N
    out = []
    for m in range(N):
        k = 2 * np.pi * m / L
        x2 = (2 / h * np.sin(k * h / 2)) ** 2
        x1 = np.sin(k * h) / h
        A = np.array([[0, 0, -1j * phi0 * x1],
                      [1j * c["a1"] * x1, -c["b11"] * x2, -c["b12"] * x2],
                      [1j * c["a2"] * x1, -c["b21"] * x2, -c["b22"] * x2]])
        out.extend(np.linalg.eigvals(A))
    return np.array(out)


def fd_max_growth(name, phi0, uz0, wz0, N, L=30.0, material=None, dense=True):
    """Largest real part of the spectrum of the linearised FD operator with N cells."""
    if dense:
        ev = np.linalg.eigvals(fd_jacobian(name, phi0, uz0, wz0, N, L, material))
    else:
        ev = fd_symbol_eigenvalues(name, phi0, uz0, wz0, N, L, material)
    return float(ev.real.max())


def fd_growth_table(Ns=(32, 64, 128, 256, 512, 1024), state=None, L=30.0, material=None, dense_max=256):
    """Max growth rate vs N for both rheologies (dense eig up to `dense_max` cells, exact symbol beyond)."""
    state = dict(DEFAULT_STATE if state is None else state)
    rows = []
    for N in Ns:
        row = {"N": N, "h": L / N}
        for name in ("mui", "icidr"):
            row[name] = fd_max_growth(name, state["phi"], state["uz"], state["wz"], N, L, material,
                                      dense=N <= dense_max)
        rows.append(row)
    return rows


def plot_fd_growth(path="docs/fd_growth.png", Ns=(32, 64, 128, 256, 512, 1024, 2048), state=None, L=30.0,
                   material=None):
    """Plot max Re(spectrum) of the linearised FD operator vs grid spacing h; save a PNG at `path`."""
    import matplotlib  # noqa: PLC0415
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    state = dict(DEFAULT_STATE if state is None else state)
    rows = fd_growth_table(Ns, state, L, material)
    h = np.array([r["h"] for r in rows])
    sn = stability_numbers("mui", state["phi"], state["uz"], state["wz"], material=material)
    fig, ax = plt.subplots(figsize=(6, 4.2))
    ax.loglog(h, [r["mui"] for r in rows], "o-", color="C3", label=r"$\mu(I),\Phi(I)$")
    ax.loglog(h, [max(r["icidr"], 1e-12) for r in rows], "s-", color="C0", label="iCIDR")
    ax.loglog(h, 4 * sn.lambda_plus.real / h**2, "k--", lw=1, label=r"$4\Lambda_+/h^2$ (symbol, $kh=\pi$)")
    lim = stability_numbers("icidr", state["phi"], state["uz"], state["wz"], material=material).lambda0_limit
    ax.axhline(lim, color="C0", ls=":", lw=1, label=r"iCIDR bound $-C/B$ ($\xi\to\infty$)")
    ax.invert_xaxis()
    ax.set_xlabel("grid spacing $h$ (grain diameters)")
    ax.set_ylabel("max Re(eigenvalue) of linearised FD operator")
    ax.set_title(rf"$\phi_0$={state['phi']}, $u_z$={state['uz']:.4g}, $w_z$={state['wz']:.4g} (periodic, L={L:g})",
                 fontsize=9)
    ax.legend()
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
    plt.close(fig)
    return path, rows
