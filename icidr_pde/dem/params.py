"""DEM parameters of appendix C (Schaeffer et al. 2019), non-dimensional (3.12).

Units: d (mean diameter) = rho_* = V0 = 1.  Disks of diameters 0.8, 0.9, 1.0,
1.1, 1.2 d in equal numbers; linear spring-dashpot normal force k_n = 1e4,
eta_n = 4.2 (restitution ~0.9 for two unit disks); tangential spring
k_t = 0.5 k_n, no tangential dashpot, Coulomb friction mu_p = 0.4.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

DIAMETER_CLASSES = (0.8, 0.9, 1.0, 1.1, 1.2)
#: bytes of LAMMPS's memory per disk of a run: about twice the peak RSS per disk of a random
#: 2-D packing after ``run 0`` (measured in docs/dem.md), for the neighbour lists and contact
#: histories of a sheared dense packing, which that measurement does not hold
LAMMPS_BYTES_PER_DISK = 1200.0


def _check_range(name, value, lo, hi, lo_open=True, hi_open=True):
    ok_lo = value > lo if lo_open else value >= lo
    ok_hi = value < hi if hi_open else value <= hi
    if not (isinstance(value, (int, float, np.integer, np.floating)) and math.isfinite(value)
            and ok_lo and ok_hi):
        lb = "(" if lo_open else "["
        rb = ")" if hi_open else "]"
        raise ValueError(f"`{name}` must lie in {lb}{lo}, {hi}{rb}; got {value!r}")


@dataclass(frozen=True)
class DEMParams:
    """Contact law and cell of appendix C.

    Args:
        n_particles: number of disks N (multiple of 5, >= 10)
        H: cell height (Lees-Edwards direction, paper's z, LAMMPS y), > 4 d
        V0: velocity jump across H imposed by Lees-Edwards (1 in the paper)
        k_n: normal spring constant (1e4)
        eta_n: normal dashpot (4.2, mass/time)
        kt_over_kn: tangential/normal stiffness ratio (0.5)
        mu_p: particle friction coefficient (0.4)
        rho: intrinsic grain density rho_* (mass per area, 1)
        dt_fraction: time step as a fraction of the shortest contact time
        bin_height: coarse-graining bin height (2 d, appendix C)
    """

    n_particles: int = 1000
    H: float = 30.0
    V0: float = 1.0
    k_n: float = 1.0e4
    eta_n: float = 4.2
    kt_over_kn: float = 0.5
    mu_p: float = 0.4
    rho: float = 1.0
    dt_fraction: float = 1.0 / 50.0
    bin_height: float = 2.0

    def __post_init__(self):
        n = self.n_particles
        if not isinstance(n, (int, np.integer)) or n < 10 or n % 5:
            raise ValueError(f"`n_particles` must be an integer multiple of 5 in [10, inf); got {n!r}")
        _check_range("H", self.H, 4.0, math.inf)
        _check_range("V0", self.V0, 0.0, math.inf)
        _check_range("k_n", self.k_n, 0.0, math.inf)
        _check_range("eta_n", self.eta_n, 0.0, math.inf, lo_open=False)
        _check_range("kt_over_kn", self.kt_over_kn, 0.0, math.inf, lo_open=False)
        _check_range("mu_p", self.mu_p, 0.0, math.inf, lo_open=False)
        _check_range("rho", self.rho, 0.0, math.inf)
        _check_range("dt_fraction", self.dt_fraction, 0.0, 0.2, hi_open=False)
        _check_range("bin_height", self.bin_height, 0.0, self.H, hi_open=False)
        if abs(self.H / self.bin_height - round(self.H / self.bin_height)) > 1e-9:
            raise ValueError(f"`bin_height` must divide H={self.H}; got {self.bin_height}")
        self.check_memory()

    def memory_bytes(self) -> float:
        """Bytes a run of this cell needs, roughly: LAMMPS's per disk and the analysis's copies of
        the positions, velocities, radii, masses, ids and of the coarse-graining weights (three
        periodic images x the bins) of every disk. Computed from n_particles, before anything is
        allocated."""
        bins = max(1.0, self.H / self.bin_height)
        return self.n_particles * (LAMMPS_BYTES_PER_DISK + 8.0 * (9 + 3 * bins))

    def check_memory(self) -> None:
        """Refuse (ValueError naming `n_particles`) a cell whose run needs more than half the memory
        available: the PDE paths' check (:func:`icidr_pde.discretizations.grid_size.check_memory`)."""
        from ..discretizations.grid_size import check_memory

        check_memory(f"`n_particles` = {self.n_particles} is too large: a DEM run of it", self.memory_bytes(),
                     "LAMMPS's atoms, neighbour lists and contacts, the analysis's copies")

    # ---- derived quantities -------------------------------------------------
    @property
    def n_bins(self) -> int:
        return int(round(self.H / self.bin_height))

    @property
    def shear_rate(self) -> float:
        return self.V0 / self.H

    def mean_disk_area(self) -> float:
        """Average grain area A-bar of the five equally populated classes."""
        return float(np.mean([math.pi * d * d / 4 for d in DIAMETER_CLASSES]))

    def box_length(self, phi0: float) -> float:
        """L = A-bar N / (H phi0) (appendix C), so the packing fraction is phi0 exactly."""
        check_phi0(phi0)
        return self.mean_disk_area() * self.n_particles / (self.H * phi0)

    def contact_time(self, d1: float, d2: float) -> float:
        """Duration of a binary collision of the damped linear spring (half period)."""
        m1, m2 = (self.rho * math.pi * d * d / 4 for d in (d1, d2))
        m_eff = m1 * m2 / (m1 + m2)
        w0sq = self.k_n / m_eff
        beta = self.eta_n / (2 * m_eff)
        if beta * beta >= w0sq:
            raise ValueError("`eta_n` overdamps the contact; no contact time")
        return math.pi / math.sqrt(w0sq - beta * beta)

    def restitution(self, d1: float = 1.0, d2: float = 1.0) -> float:
        """Normal restitution e = exp(-beta t_c) of the linear spring-dashpot."""
        m1, m2 = (self.rho * math.pi * d * d / 4 for d in (d1, d2))
        m_eff = m1 * m2 / (m1 + m2)
        return math.exp(-self.eta_n / (2 * m_eff) * self.contact_time(d1, d2))

    @property
    def dt(self) -> float:
        """Time step = dt_fraction x shortest contact time (two 0.8 d disks)."""
        dmin = min(DIAMETER_CLASSES)
        return self.dt_fraction * self.contact_time(dmin, dmin)

    def diameters(self, rng: np.random.Generator) -> np.ndarray:
        """N/5 disks of each class 0.8..1.2 d, randomly ordered."""
        d = np.repeat(np.array(DIAMETER_CLASSES), self.n_particles // 5)
        rng.shuffle(d)
        return d


def check_phi0(phi0) -> float:
    """Validate a mean packing fraction (2-D disks: random close packing ~0.84)."""
    _check_range("phi0", phi0, 0.05, 0.84)
    return float(phi0)
