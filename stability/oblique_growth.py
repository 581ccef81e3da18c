"""Measured growth of single oblique plane waves in the linearised 2-D system.

The 2-D analogue of :func:`stability.growth.measured_growth_rate`: the frozen-coefficient
2-D equations (principal part, see :mod:`stability.plane`)

    phi_t = -phi0 div u',   u'_t = div sigma(phi0 + phi', L + grad u') / (rho_* phi0)

are linearised about u' = 0, phi' = 0 by complex-step differentiation of the compiled 2-D
stress tensor sigma(phi, grad u) (so not through the symbolic a_ij, B_ijkl that the
symbol A(xi, n) is built from), on a doubly periodic box that carries the plane wave
exp(i xi n.x), n = (cos theta, sin theta), with pseudo-spectral derivatives restricted
to that wave (and its conjugate).  The linear system is integrated in time (DOP853, or
Radau when stiff) and the slope of log ||state|| after the subdominant roots have decayed
is compared with max Re eig A(xi, n) of :func:`stability.directional.symbol_matrix`.
"""

from __future__ import annotations


import numpy as np
from scipy.integrate import solve_ivp
from icidr_pde.outputs import save_figure

from . import directional
from .material import check_xi


def stress_field(rheology, phi_f, grad_u, material=None):
    """sigma_ij (2, 2, ...) of the law on fields phi_f (...) and grad_u (2, 2, ...); complex input allowed."""
    f, params = directional.compiled("stress", directional._law(rheology), material)
    s = f(phi_f, grad_u[0, 0], grad_u[0, 1], grad_u[1, 0], grad_u[1, 1], *params)
    shape = np.broadcast(phi_f, grad_u[0, 0]).shape
    return np.array([np.broadcast_to(np.asarray(v), shape) for v in s]).reshape(2, 2, *shape)


class PlaneWaveBox:
    """Doubly periodic box carrying exp(i xi n.x) as its Fourier mode (1, 1) (or (0, 1), (1, 0)).

    A zero wave-vector component gets one grid point in that direction.
    """

    def __init__(self, xi, angle_deg, n_points=4):
        th = np.deg2rad(angle_deg)
        self.k = xi * np.array([np.cos(th), np.sin(th)])
        self.k[np.abs(self.k) < 1e-12 * xi] = 0.0
        self.shape = tuple(1 if kc == 0 else int(n_points) for kc in self.k)
        self.length = tuple(2 * np.pi / abs(kc) if kc else 1.0 for kc in self.k)
        kx = 2 * np.pi * np.fft.fftfreq(self.shape[0], self.length[0] / self.shape[0])
        kz = 2 * np.pi * np.fft.fftfreq(self.shape[1], self.length[1] / self.shape[1])
        self.KX, self.KZ = np.meshgrid(kx, kz, indexing="ij")
        on = lambda K, kc: np.isclose(K, kc, atol=1e-9 * xi)  # noqa: E731
        self.mask = (on(self.KX, self.k[0]) & on(self.KZ, self.k[1])) | (on(self.KX, -self.k[0]) & on(self.KZ, -self.k[1]))
        x = np.arange(self.shape[0]) * self.length[0] / self.shape[0]
        z = np.arange(self.shape[1]) * self.length[1] / self.shape[1]
        self.X, self.Z = np.meshgrid(x, z, indexing="ij")

    @property
    def size(self):
        return self.shape[0] * self.shape[1]

    def project(self, f):
        """Keep only the plane wave (and its conjugate) of a field."""
        return np.fft.ifft2(self.mask * np.fft.fft2(f))

    def grad(self, f):
        """(d_x f, d_z f) restricted to the plane wave (complex fields allowed)."""
        F = self.mask * np.fft.fft2(f)
        return np.fft.ifft2(1j * self.KX * F), np.fft.ifft2(1j * self.KZ * F)


def frozen_rhs(rheology, phi0, L, box, material=None):
    """U -> dU/dt of the frozen-coefficient 2-D principal part (complex U allowed)."""
    L = np.asarray(L, dtype=float).reshape(2, 2)

    def rhs(U):
        ph, u, w = (U[j * box.size:(j + 1) * box.size].reshape(box.shape) for j in range(3))
        ux, uz = box.grad(u)
        wx, wz = box.grad(w)
        grad_u = np.array([[L[0, 0] + ux, L[0, 1] + uz], [L[1, 0] + wx, L[1, 1] + wz]])
        sig = stress_field(rheology, phi0 + ph, grad_u, material)
        div = [box.grad(sig[i, 0])[0] + box.grad(sig[i, 1])[1] for i in range(2)]
        return np.concatenate([(-phi0 * (ux + wz)).ravel(), (div[0] / phi0).ravel(), (div[1] / phi0).ravel()])

    return rhs


def linear_operator(rheology, phi0, velocity_gradient, box, material=None, h=1e-30):
    """Jacobian of :func:`frozen_rhs` at U = 0 by complex-step differentiation (exact to rounding)."""
    rhs = frozen_rhs(rheology, phi0, velocity_gradient, box, material)
    n = 3 * box.size
    J = np.empty((n, n))
    for k in range(n):
        e = np.zeros(n, dtype=complex)
        e[k] = 1j * h
        J[:, k] = rhs(e).imag / h
    return J


def measured_growth_rate(rheology, phi0, velocity_gradient, xi, angle_deg, material=None, n_points=4, seed=0,
                         rtol=1e-10):
    """Growth rate of the plane wave exp(i xi n.x) measured by time integration of the linearised 2-D system.

    Returns dict(xi, angle_deg, measured, predicted = max Re eig A(xi, n), rel_error, method).
    Random real initial amplitudes of the wave for (phi, u, w); the integration time is set
    from the spectral gap so that the other roots are suppressed by e^-25 before measuring.
    """
    xi = check_xi(xi)
    a, B = directional.principal_part(rheology, phi0, velocity_gradient, material)
    ev = np.linalg.eigvals(directional.symbol_matrix(a, B, float(phi0), xi, angle_deg))
    re = np.sort(ev.real)[::-1]
    predicted, gap = float(re[0]), float(re[0] - re[1])
    if gap <= 1e-9 * max(1.0, abs(re[0])):
        raise ValueError(f"`xi` = {xi}, angle {angle_deg}: dominant root not separated (gap {gap:g})")
    box = PlaneWaveBox(xi, angle_deg, n_points)
    J = linear_operator(rheology, float(phi0), velocity_gradient, box, material)
    rng = np.random.default_rng(seed)
    phase = box.k[0] * box.X + box.k[1] * box.Z
    y = np.concatenate([(c * np.cos(phase) + s * np.sin(phase)).ravel() for c, s in rng.normal(size=(3, 2))])
    y /= np.linalg.norm(y)
    t_settle = 25.0 / gap
    t_measure = max(25.0 / gap, 0.5 / max(abs(predicted), 1e-3))
    stiff = abs(float(re[-1])) * (t_settle + t_measure) > 2e4
    method = "Radau" if stiff else "DOP853"
    chunk = 10.0 / max(abs(predicted), 1e-12)          # renormalise before the norm changes by e^10
    fun = lambda _t, v: J @ v  # noqa: E731
    logn, t, log_settle = 0.0, 0.0, None
    for t_stop in (t_settle, t_settle + t_measure):
        while t < t_stop - 1e-15 * t_stop:
            dt = min(chunk, t_stop - t)
            sol = solve_ivp(fun, (0.0, dt), y, method=method, rtol=rtol, atol=rtol * 1e-3,
                            **({"jac": J} if stiff else {}))
            y = _project(sol.y[:, -1], box)
            nrm = np.linalg.norm(y)
            logn += np.log(nrm)
            y /= nrm
            t += dt
        if log_settle is None:
            log_settle = logn
    measured = (logn - log_settle) / t_measure
    return {"xi": xi, "angle_deg": float(angle_deg), "measured": float(measured), "predicted": predicted,
            "rel_error": float(abs(measured - predicted) / abs(predicted)), "method": method}


def _project(y, box):
    n = box.size
    return np.concatenate([box.project(y[j * n:(j + 1) * n].reshape(box.shape)).real.ravel() for j in range(3)])


def growth_table(state=None, angles_deg=range(0, 180, 10), xis=(10.0, 100.0), material=None):
    """Measured vs predicted growth of oblique waves for both rheologies: list of dict rows."""
    phi0, L = state or (0.78, (0.0, 1.0 / 30.0, 0.0, 0.0))
    rows = []
    for name in ("mui", "icidr"):
        for xi in xis:
            for th in angles_deg:
                g = measured_growth_rate(name, phi0, L, xi, float(th), material)
                rows.append({"rheology": name, **g})
    return rows


def plot_oblique_growth(path="docs/oblique_growth.png", state=None, rows=None, material=None):
    """Measured growth of single oblique waves against Lambda_max(theta) and the symbol; PNG at `path`.

    (a) mu(I),Phi(I): measured rate / xi^2 against Lambda_max(theta) (the O(xi^2) roots) and the
    bounded third root / xi^2; (b) iCIDR: measured rates (bounded) against max Re eig A(xi, n)
    and the xi -> oo limit phi n.Gamma^-1 alpha.  Returns (path, rows).
    """
    import matplotlib  # noqa: PLC0415
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    phi0, L = state or (0.78, (0.0, 1.0 / 30.0, 0.0, 0.0))
    rows = growth_table((phi0, L), material=material) if rows is None else rows
    fine = np.arange(0.0, 180.0, 0.25)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for ax, name in zip(axes, ("mui", "icidr")):
        r = directional.directional_stability(name, phi0, L, fine, material)
        a, B = directional.principal_part(name, phi0, L, material)
        mine = [x for x in rows if x["rheology"] == name]
        xis = sorted({x["xi"] for x in mine})
        if name == "mui":
            ax.plot(fine, r.lambda_max, "k-", lw=1.5, label=r"$\Lambda_{max}(\theta)$ (symbol, $\xi\to\infty$)")
            for c, mk, xi in zip(("C3", "C1"), ("o", "x"), xis):
                sel = [x for x in mine if x["xi"] == xi]
                ax.plot([x["angle_deg"] for x in sel], [x["measured"] / xi**2 for x in sel], mk, mfc="none",
                        color=c, ms=8 if mk == "o" else 6, label=rf"measured rate$/\xi^2$, $\xi$ = {xi:g}")
            ax.set_ylabel(r"growth rate / $\xi^2$")
            for lo, hi in r.ill_posed_intervals_deg:
                ax.axvspan(lo, hi, color="C3", alpha=0.1, lw=0)
        else:
            ax.plot(fine, r.lambda0_limit.real, "k-", lw=1.5, label=r"third root limit $\phi_0\,n\cdot\Gamma^{-1}\alpha$")
            for c, mk, xi in zip(("C0", "C2"), ("o", "x"), xis):
                sel = [x for x in mine if x["xi"] == xi]
                pred = [np.linalg.eigvals(directional.symbol_matrix(a, B, phi0, xi, t)).real.max() for t in fine]
                ax.plot(fine, pred, "--", color=c, lw=1, label=rf"max Re eig $A(\xi, n)$, $\xi$ = {xi:g}")
                ax.plot([x["angle_deg"] for x in sel], [x["measured"] for x in sel], mk, mfc="none", color=c,
                        ms=8 if mk == "o" else 6,
                        label=rf"measured rate, $\xi$ = {xi:g}")
            ax.set_ylabel("growth rate (bounded in $\\xi$)")
            ax.text(0.02, 0.04, rf"$\Lambda_{{max}}(\theta)$ = {r.max_lambda:.4g} at every $\theta$ (all < 0)",
                    transform=ax.transAxes, fontsize=8)
        ax.axhline(0, color="0.5", lw=0.6)
        ax.set_xlabel(r"wave direction $\theta$ (deg); 90 = the 1-D direction")
        ax.set_xticks(range(0, 181, 30))
        ax.set_title(("(a) " + r"$\mu(I),\Phi(I)$") if name == "mui" else "(b) iCIDR", fontsize=10)
        ax.legend(fontsize=7)
    err = max(x["rel_error"] for x in rows)
    fig.suptitle(rf"single oblique waves, linearised 2-D system: $\phi_0$ = {phi0:g}, $\nabla u$ = "
                 rf"[[{L[0]:g}, {L[1]:.4g}], [{L[2]:g}, {L[3]:g}]]; max |measured/predicted - 1| = {err:.1e}",
                 fontsize=9)
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
    plt.close(fig)
    return path, rows
