"""Coarse graining of appendix C: x-averages in bins of height 2 d.

Per bin b of height h and width L (the whole periodic cell):

* packing fraction phi_b = (disk area inside the slab) / (h L), with the exact
  circle-slab intersection (periodic in z), so the bin mean of phi is exactly
  the total disk area / (H L) = phi0 of appendix C;
* velocities u_b, w_b: mass-weighted means of the material in the slab
  (:func:`layer_moments` also gives the two other definitions studied);
* stress by (C1): the pressure-like (compression positive) tensor
  P_ij = 1/(h L) sum_{alpha in b} [ 1/2 sum_beta r_i f_j + m dv_i dv_j ]
  where the first term is the per-particle pair virial (half of each contact
  to each partner) and dv = (u - V0 z/H - c, w) is the fluctuation about the
  imposed linear profile of (C1) (c: the cell's mean streaming offset, zero
  in a frame where the bottom moves at 0).  The Cauchy stress of (2.3) is
  sigma = -P, so p = (P_xx + P_zz)/2 and
  ||tau|| = sqrt(((P_xx - P_zz)/2)^2 + P_xz^2).
"""

from __future__ import annotations

import numpy as np


def _below(h: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Area of a disk of radius R lying below height h measured from its centre."""
    hc = np.clip(h, -R, R)
    return hc * np.sqrt(np.maximum(R * R - hc * hc, 0.0)) + R * R * (np.arcsin(hc / R) + np.pi / 2)


IMAGE_SHIFTS = (-1, 0, 1)


def slab_areas(z: np.ndarray, radius: np.ndarray, edges: np.ndarray, H: float,
               per_image: bool = False) -> np.ndarray:
    """Area of each disk inside each slab [edges[b], edges[b+1]), periodic in z.

    Returns shape (n_particles, n_bins), or with ``per_image`` shape
    (3, n_particles, n_bins) split by the periodic image z - H, z, z + H.
    """
    z = np.asarray(z, float)
    R = np.asarray(radius, float)[:, None]
    out = np.zeros((len(IMAGE_SHIFTS), z.size, edges.size - 1))
    for k, shift in enumerate(IMAGE_SHIFTS):
        zc = (np.mod(z, H) + shift * H)[:, None]
        cum = _below(edges[None, :] - zc, R)
        out[k] = np.diff(cum, axis=1)
    return out if per_image else out.sum(axis=0)


def bin_edges(H: float, bin_height: float) -> np.ndarray:
    if not bin_height > 0 or bin_height > H:
        raise ValueError(f"`bin_height` must lie in (0, H={H}]; got {bin_height}")
    n = int(round(H / bin_height))
    if abs(n * bin_height - H) > 1e-9 * H:
        raise ValueError(f"`bin_height` must divide H={H}; got {bin_height}")
    return np.linspace(0.0, H, n + 1)


#: velocity definitions of :func:`layer_moments` (see there)
VELOCITY_DEFINITIONS = ("slab_mass", "area_times_mass", "centre")


def layer_moments(z, u, w, radius, mass, L, H, bin_height=1.0, V0=0.0) -> dict:
    """Additive per-bin sums from which phi, u, w follow for any coarser bin and
    for each velocity definition (arrays of shape (n_bins,)).

    * ``area``: disk area inside the slab (phi = area / (h L));
    * ``slab_mass``: each disk contributes the mass of its part inside the slab,
      rho_alpha A_alpha,b (rho_alpha = m_alpha / pi r_alpha^2), and that part's
      momentum -- the mass-weighted velocity of the material in the slab;
    * ``area_times_mass``: weights A_alpha,b m_alpha (the definition used before;
      it over-weights large disks as r^4);
    * ``centre``: each disk counted whole in the bin holding its centre, with
      weight m_alpha (the usual particle-binning estimate).

    ``V0`` is the Lees-Edwards jump: the part of a disk that sticks out through
    z = H (z = 0) belongs to its image and moves at u + V0 (u - V0).
    Keys: area, m_<def>, pu_<def>, pw_<def> for each definition.
    """
    if not L > 0:
        raise ValueError(f"`L` must be > 0; got {L}")
    edges = bin_edges(H, bin_height)
    A3 = slab_areas(z, radius, edges, H, per_image=True)
    A = A3.sum(axis=0)
    m = np.asarray(mass, float)
    R = np.asarray(radius, float)
    u = np.asarray(u, float)
    w = np.asarray(w, float)
    rho = m / (np.pi * R * R)
    out = {"area": A.sum(axis=0)}
    for name, wt in (("slab_mass", rho), ("area_times_mass", m)):
        W3 = A3 * wt[None, :, None]
        out[f"m_{name}"] = W3.sum(axis=(0, 1))
        out[f"pu_{name}"] = sum((W3[k] * (u + shift * V0)[:, None]).sum(axis=0)
                                for k, shift in enumerate(IMAGE_SHIFTS))
        out[f"pw_{name}"] = (W3.sum(axis=0) * w[:, None]).sum(axis=0)
    nb = edges.size - 1
    idx = np.clip(np.searchsorted(edges, np.mod(np.asarray(z, float), H), side="right") - 1, 0, nb - 1)
    out["m_centre"] = np.bincount(idx, m, minlength=nb)
    out["pu_centre"] = np.bincount(idx, m * u, minlength=nb)
    out["pw_centre"] = np.bincount(idx, m * w, minlength=nb)
    return out


def fields_from_moments(mom: dict, L: float, bin_height: float, definition="slab_mass", merge=1):
    """phi, u, w from :func:`layer_moments` sums (any leading axes, bins last),
    after merging ``merge`` consecutive bins (the sums are additive, so merging
    is exact).  Returns (phi, u, w)."""
    if definition not in VELOCITY_DEFINITIONS:
        raise ValueError(f"`definition` must be one of {VELOCITY_DEFINITIONS}; got {definition!r}")
    nb = np.asarray(mom["area"]).shape[-1]
    if not isinstance(merge, (int, np.integer)) or merge < 1 or nb % merge:
        raise ValueError(f"`merge` must be a positive divisor of the {nb} bins; got {merge!r}")

    def agg(a):
        a = np.asarray(a, float)
        return a.reshape(*a.shape[:-1], nb // merge, merge).sum(-1)

    m = agg(mom[f"m_{definition}"])
    with np.errstate(invalid="ignore", divide="ignore"):
        u = agg(mom[f"pu_{definition}"]) / m
        w = agg(mom[f"pw_{definition}"]) / m
    return agg(mom["area"]) / (L * bin_height * merge), u, w


def profiles(z, u, w, radius, mass, L, H, bin_height=2.0, V0=0.0, definition="slab_mass"):
    """phi, u, w per bin (appendix C).  Returns (centres, phi, u, w).

    Velocities are the mass-weighted means of the material in each slab (see
    :func:`layer_moments` for the definitions).  ``V0`` is the Lees-Edwards
    velocity jump: the part of a disk that sticks out through z = H moves with
    u + V0 (u - V0 through z = 0).
    """
    mom = layer_moments(z, u, w, radius, mass, L, H, bin_height, V0)
    phi, ub, wb = fields_from_moments(mom, L, bin_height, definition)
    edges = bin_edges(H, bin_height)
    return 0.5 * (edges[1:] + edges[:-1]), phi, ub, wb


def streaming_offset(z, u, mass, V0, H) -> float:
    """Mass-weighted mean of u - V0 z/H: the constant c of the linear profile."""
    m = np.asarray(mass)
    return float(np.sum(m * (np.asarray(u) - V0 * np.mod(z, H) / H)) / m.sum())


def stress_profile(z, u, w, mass, virial, L, H, V0, bin_height=2.0, offset=None):
    """(C1) per bin: compression-positive tensor columns (xx, zz, xz), shape (n_bins, 3).

    Args:
        virial: per-particle pair virial 1/2 sum_beta r_i f_j, columns (xx, zz, xz)
        offset: constant c in the reference profile V0 z/H + c (default: measured)
    """
    edges = bin_edges(H, bin_height)
    zz = np.mod(np.asarray(z, float), H)
    m = np.asarray(mass, float)
    if offset is None:
        offset = streaming_offset(zz, u, m, V0, H)
    du = np.asarray(u) - V0 * zz / H - offset
    dw = np.asarray(w, float)
    per = np.asarray(virial, float) + np.stack([m * du * du, m * dw * dw, m * du * dw], axis=1)
    idx = np.clip(np.searchsorted(edges, zz, side="right") - 1, 0, edges.size - 2)
    out = np.zeros((edges.size - 1, 3))
    np.add.at(out, idx, per)
    return out / (L * np.diff(edges))[:, None]


def invariants(P):
    """p, ||tau||, mu from compression-positive (xx, zz, xz) tensors, (2.3)."""
    P = np.asarray(P, float)
    p = 0.5 * (P[..., 0] + P[..., 1])
    tau = np.sqrt((0.5 * (P[..., 0] - P[..., 1])) ** 2 + P[..., 2] ** 2)
    with np.errstate(invalid="ignore", divide="ignore"):
        mu = tau / p
    return p, tau, mu


def inertial_number(shear_rate, p, d=1.0, rho=1.0):
    """I = 2 d ||S|| / sqrt(p/rho) (2.9); simple shear has ||S|| = |du/dz|/2."""
    p = np.asarray(p, float)
    if np.any(p <= 0):
        raise ValueError("`p` must be > 0 to define the inertial number (2.9)")
    return np.abs(shear_rate) * d / np.sqrt(p / rho)
