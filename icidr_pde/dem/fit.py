"""Least-squares fits of the steady rheology, (2.10) and (2.11).

* (2.10) mu(I) = mu_s + (mu_d - mu_s)/(I0/I + 1): weighted non-linear least
  squares (scipy ``curve_fit``) with sigma = standard error of mu over repeats.
* (2.11) Phi(I) = phi_c - a I.  In the DEM phi = phi0 is imposed and I is the
  measured (noisy) quantity, so we regress I on phi, I = (phi_c - phi)/a
  (the inverse (2.13)), weighted by the standard error of I, and propagate
  the covariance of (slope, intercept) to (a, phi_c).

Parameter uncertainties are one standard deviation from the covariance
(``absolute_sigma=False``: scaled by the reduced chi^2, so they reflect the
actual scatter about the fitted curve).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import curve_fit

from ..rheology import mu_of_I


def _sigma(std, n):
    if std is None:
        return None
    s = np.asarray(std, float) / np.sqrt(max(n, 1))
    if np.all(s > 0):
        return s
    return None


def fit_mu(I, mu, mu_std=None, n_repeats=1, p0=(0.25, 0.6, 0.15), return_corr=False,
           absolute_sigma=False):
    """Fit (2.10); returns (params dict, std dict[, correlation matrix (mu_s, mu_d, I0)]).

    ``absolute_sigma=True`` takes the errors as known standard errors (the parameter
    covariance is not rescaled by the reduced chi^2)."""
    I, mu = np.asarray(I, float), np.asarray(mu, float)
    if I.size < 3 or np.any(I <= 0):
        raise ValueError("`I` must hold at least 3 positive inertial numbers to fit (2.10)")
    popt, pcov = curve_fit(
        mu_of_I, I, mu, p0=p0, sigma=_sigma(mu_std, n_repeats), absolute_sigma=absolute_sigma,
        bounds=([0.0, 0.0, 1e-4], [2.0, 5.0, 10.0]), maxfev=20000,
    )
    perr = np.sqrt(np.abs(np.diag(pcov)))
    names = ("mu_s", "mu_d", "I0")
    out = dict(zip(names, map(float, popt))), dict(zip(names, map(float, perr)))
    if return_corr:
        return (*out, (pcov / np.outer(perr, perr)).tolist())
    return out


def fit_phi(I, phi, I_std=None, n_repeats=1, absolute_sigma=False):
    """Fit (2.11) by regressing I on phi; returns (params dict, std dict).
    ``absolute_sigma`` as in :func:`fit_mu`."""
    I, phi = np.asarray(I, float), np.asarray(phi, float)
    if I.size < 2:
        raise ValueError("`I` must hold at least 2 points to fit (2.11)")
    s = _sigma(I_std, n_repeats)
    w = None if s is None else 1.0 / s
    # I = c0 + c1 phi with c1 = -1/a, c0 = phi_c/a
    if I.size > 2:
        coef, cov = np.polyfit(phi, I, 1, w=w, cov="unscaled" if (absolute_sigma and w is not None) else True)
    else:
        coef, cov = np.polyfit(phi, I, 1, w=w), np.zeros((2, 2))
    c1, c0 = coef
    a = -1.0 / c1
    phi_c = -c0 / c1
    # Jacobians d(a, phi_c)/d(c1, c0)
    J = np.array([[1.0 / c1**2, 0.0], [c0 / c1**2, -1.0 / c1]])
    C = J @ cov @ J.T
    return {"phi_c": float(phi_c), "a": float(a)}, {
        "phi_c": float(np.sqrt(abs(C[1, 1]))), "a": float(np.sqrt(abs(C[0, 0])))}
