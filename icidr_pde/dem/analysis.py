"""Statistics of the fig 8 transient ensembles: secondary peak, errors, local rheology.

Conventions (docs/dem.md, section "Protocol audit"):

* ensemble fields are means over members on 2 d bins unless a bin size is given;
* ``max_w(t) = max_z |<w>(z, t)|`` (the paper's fig 7(e)/8(d) quantity) and its
  *secondary peak*: the largest value for t >= 1.5, with its time;
* ``W1(t)``: least-squares amplitude of the first sine mode of <w> on the bins
  (w ~ W1 sin(2 pi z/H) at late times in both DEM and iCIDR), much less noisy
  than a maximum over bins; its decay rate over 5 <= t <= 15;
* uncertainties: bootstrap over members (members resampled with replacement,
  every statistic recomputed), the standard deviation of the bootstrap
  distribution quoted as the standard error;
* errors against iCIDR: E_f(t) = RMS_bins(f_iCIDR - <f>_DEM)/S_f (S_phi = phi0,
  S_u = S_w = V0, the existing normalised metric) and the error *relative to
  the perturbation* R_f = sqrt(sum_t,b (f_iCIDR - <f>_DEM)^2 / sum_t,b
  (<f>_DEM - f_steady)^2) with f_steady = phi0, V0 z/H, 0 over 0 < t <= t_end.
"""

from __future__ import annotations

import numpy as np

from . import coarse
from . import ensemble as E

T_SECONDARY = 1.5
DECAY_WINDOW = (5.0, 15.0)


def stack(results, bin_height=2.0, definition="slab_mass", frame="offset"):
    """Member fields on common bins: dict times, z, H, phi, u, w with shape (R, T, B)."""
    if not results:
        raise ValueError("`results` is empty")
    out = {"phi": [], "u": [], "w": []}
    for r in results:
        t, z, phi, u, w = E.fields(r, bin_height, definition, frame)
        out["phi"].append(phi), out["u"].append(u), out["w"].append(w)
    out = {k: np.array(v) for k, v in out.items()}
    out.update(times=t, z=z, H=float(results[0]["H"]), V0=float(results[0]["V0"]),
               L=np.array([float(r["L"]) for r in results]), bin_height=bin_height)
    return out


def sine_basis(z, H, bin_height):
    """Bin averages of sin(2 pi z/H) on bins centred at z."""
    k = 2 * np.pi / H
    lo, hi = z - bin_height / 2, z + bin_height / 2
    return (np.cos(k * lo) - np.cos(k * hi)) / (k * bin_height)


def mode_amplitude(w, z, H, bin_height):
    """Least-squares W1 in w ~ W1 sin(2 pi z/H) (last axis = bins)."""
    s = sine_basis(z, H, bin_height)
    return np.asarray(w) @ s / (s @ s)


def secondary_peak(t, series, t_min=T_SECONDARY):
    t = np.asarray(t)
    sel = t >= t_min
    k = int(np.argmax(np.asarray(series)[sel]))
    return float(t[sel][k]), float(np.asarray(series)[sel][k])


def decay_rate(t, series, window=DECAY_WINDOW):
    """-d ln|series|/dt fitted over ``window`` (series of one sign there)."""
    t = np.asarray(t)
    sel = (t >= window[0]) & (t <= window[1])
    y = np.abs(np.asarray(series)[sel])
    if np.any(y <= 0):
        return float("nan")
    return float(-np.polyfit(t[sel], np.log(y), 1)[0])


def peak_stats(w_mean, t, z, H, bin_height):
    """Secondary peak of max_z|w|, of W1, and the decay rate of W1, from one mean field."""
    mw = np.abs(w_mean).max(axis=-1)
    W1 = mode_amplitude(w_mean, z, H, bin_height)
    tp, hp = secondary_peak(t, mw)
    tw, hw = secondary_peak(t, W1)
    return {"t_peak": tp, "max_w_peak": hp, "t_peak_W1": tw, "W1_peak": hw,
            "W1_decay_rate": decay_rate(t, W1),
            "max_w_at": {str(s): float(mw[np.argmin(np.abs(t - s))]) for s in (1, 3, 5, 8, 10)}}


def _flatten(d, prefix=""):
    out = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(_flatten(v, f"{prefix}{k}."))
        else:
            out[prefix + k] = v
    return out


def bootstrap(members: list, statistic, n_boot=400, seed=0):
    """Mean over members' statistic(ensemble of resampled members): returns dict
    name -> (value on the full ensemble, bootstrap standard error).

    ``members`` is a list indexed by member; ``statistic(index array)`` returns a
    (possibly nested) dict of floats computed from those members.
    """
    rng = np.random.default_rng(seed)
    n = len(members)
    full = _flatten(statistic(np.arange(n)))
    samples = {k: [] for k in full}
    for _ in range(n_boot):
        s = _flatten(statistic(rng.integers(0, n, n)))
        for k in samples:
            samples[k].append(s[k])
    return {k: (full[k], float(np.nanstd(samples[k], ddof=1))) for k in full}


def errors(mean, cont, phi0, V0=1.0, H=30.0, z=None, se=None):
    """Normalised E_f(t) and perturbation-relative R_f of iCIDR against a DEM mean
    (dicts of (T, B) arrays); with ``se`` (standard errors of the mean) also the
    noise floor of E_f and the noise-corrected R_f (expected noise subtracted)."""
    scale = {"phi": phi0, "u": V0, "w": V0}
    steady = {"phi": phi0, "u": V0 * z / H, "w": 0.0}
    out = {}
    for f in ("phi", "u", "w"):
        d = cont[f] - mean[f]
        out[f"E_{f}"] = np.sqrt(np.mean(d**2, axis=1)) / scale[f]
        sig = (mean[f] - steady[f])[1:]
        num = np.sum(d[1:] ** 2)
        out[f"R_{f}"] = float(np.sqrt(num / np.sum(sig**2)))
        if se is not None:
            noise = np.sum(se[f][1:] ** 2)
            out[f"E_{f}_floor"] = np.sqrt(np.mean(se[f] ** 2, axis=1)) / scale[f]
            out[f"R_{f}_noise_corrected"] = float(np.sqrt(max(num - noise, 0.0) / max(np.sum(sig**2) - noise, 1e-300)))
    out["E"] = np.max(np.stack([out[f"E_{f}"] for f in ("phi", "u", "w")]), axis=0)
    return out


# ---------------------------------------------------------------- local rheology
def dem_stress(results, bin_height=2.0):
    """Ensemble-mean (C1) tensor per bin over time, compression positive, columns
    (xx, zz, xz): contact virial of the disks centred in the bin plus the kinetic
    part about the bin's own mean velocity.  Shape (T, B, 3)."""
    acc = 0.0
    for r in results:
        hb = float(r["record_bin"])
        merge = int(round(bin_height / hb))
        g = {k: np.asarray(r[f"m_{k}"], float) for k in (
            "vir_xx", "vir_zz", "vir_xz", "m_centre", "mdu_centre", "pw_centre",
            "muu_centre", "mww_centre", "muw_centre")}
        nb = g["m_centre"].shape[-1]
        g = {k: v.reshape(*v.shape[:-1], nb // merge, merge).sum(-1) for k, v in g.items()}
        m = np.maximum(g["m_centre"], 1e-300)
        kuu = g["muu_centre"] - g["mdu_centre"] ** 2 / m
        kww = g["mww_centre"] - g["pw_centre"] ** 2 / m
        kuw = g["muw_centre"] - g["mdu_centre"] * g["pw_centre"] / m
        P = np.stack([g["vir_xx"] + kuu, g["vir_zz"] + kww, g["vir_xz"] + kuw], axis=-1)
        acc = acc + P / (float(r["L"]) * bin_height)
    return acc / len(results)


def strain_rates(u, w, bin_height, V0):
    """Central differences of bin means, periodic in z with the Lees-Edwards jump V0 in u."""
    up = np.concatenate([u[..., -1:] - V0, u, u[..., :1] + V0], axis=-1)
    wp = np.concatenate([w[..., -1:], w, w[..., :1]], axis=-1)
    return ((up[..., 2:] - up[..., :-2]) / (2 * bin_height),
            (wp[..., 2:] - wp[..., :-2]) / (2 * bin_height))


def local_rheology(results, mean, bin_height=2.0, window=1.0, rho=1.0, d=1.0):
    """DEM local state against the steady laws: time-windowed (``window``) means of
    I = 2 d||S||/sqrt(p/rho) with 2||S|| = sqrt(u_z^2 + w_z^2) (1-D, (2.5), (2.9)),
    mu = ||tau||/p and phi.  Returns dict of (T', B) arrays and window centres."""
    P = dem_stress(results, bin_height)
    t = mean["times"]
    uz, wz = strain_rates(mean["u"], mean["w"], bin_height, mean["V0"])
    n = max(1, int(round(window / (t[1] - t[0]))))
    T = (t.size - 1) // n

    def win(a):
        return a[1:1 + T * n].reshape(T, n, *a.shape[1:]).mean(1)

    Pw = win(P)
    p, tau, mu = coarse.invariants(Pw)
    S2 = win(np.hypot(uz, wz))
    # Cauchy deviatoric components (sigma = -P): tau_xz = -P_xz, tau_zz = (P_xx - P_zz)/2
    return {"t": win(t), "p": p, "mu": mu, "I": S2 * d / np.sqrt(np.maximum(p, 1e-300) / rho),
            "phi": win(mean["phi"]), "uz": win(uz), "wz": win(wz),
            "tau_xz": -Pw[..., 2], "tau_zz": 0.5 * (Pw[..., 0] - Pw[..., 1])}


def constitutive_residual(lr, material=None):
    """iCIDR's stress (4.12), (4.14) evaluated on the DEM's own local state (phi, u_z,
    w_z) against the DEM's measured p and tau_xz: dict of (T', B) arrays."""
    from icidr_pde.rheology import Material, get_rheology

    material = material or Material()
    phi = np.clip(lr["phi"], 1e-3, material.phi_c - 1e-4)
    p, txz, _ = get_rheology("icidr", material).stress(phi, lr["uz"], lr["wz"])
    return {"p_icidr": np.asarray(p), "tau_xz_icidr": np.asarray(txz)}
