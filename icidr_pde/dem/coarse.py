"""Coarse graining of appendix C: x-averages in bins of height 2 d.

Per bin b of height h and width L (the whole periodic cell):

* packing fraction phi_b = (disk area inside the slab) / (h L), with the exact
  circle-slab intersection (periodic in z), so the bin mean of phi is exactly
  the total disk area / (H L) = phi0 of appendix C;
* velocities u_b, w_b: mass-weighted means with the same slab weights;
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


def profiles(z, u, w, radius, mass, L, H, bin_height=2.0, V0=0.0):
    """phi, u, w per bin (appendix C).  Returns (centres, phi, u, w).

    ``V0`` is the Lees-Edwards velocity jump: the part of a disk that sticks out
    through z = H (image z - H... z + H) moves with u + V0 (u - V0 through z = 0).
    """
    if not L > 0:
        raise ValueError(f"`L` must be > 0; got {L}")
    edges = bin_edges(H, bin_height)
    A3 = slab_areas(z, radius, edges, H, per_image=True)
    A = A3.sum(axis=0)
    phi = A.sum(axis=0) / (L * np.diff(edges))
    m = np.asarray(mass, float)[:, None]
    den = (A * m).sum(axis=0)
    u = np.asarray(u, float)[:, None]
    w = np.asarray(w, float)[:, None]
    mom_u = sum((A3[k] * m * (u + shift * V0)).sum(axis=0) for k, shift in enumerate(IMAGE_SHIFTS))
    with np.errstate(invalid="ignore", divide="ignore"):
        ub = mom_u / den
        wb = (A * m * w).sum(axis=0) / den
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
