"""LAMMPS driver for the appendix-C shear cell (one cell = one LAMMPS instance).

Geometry: LAMMPS x = paper's x (periodic, length L from phi0), LAMMPS y = paper's
z (height H).  Lees-Edwards in y is a triclinic box sheared by
``fix deform xy erate V0/H remap v flip yes``: an atom leaving through y = H
re-enters at y = 0 with its x-velocity lowered by V0 (and vice versa), so the
periodic images at +-H move at +-V0.

Protocol (appendix C): random placement of N/5 disks of each class; relaxation
of the overlaps with elastic frictionless contacts (displacement-limited,
viscously damped); then frictional contacts, velocities set to the linear
profile u = V0 y/H, and Lees-Edwards shearing to steady state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._lammps import new_lammps
from .params import DIAMETER_CLASSES, DEMParams, check_phi0


@dataclass
class Snapshot:
    """Per-particle state at one instant (LAMMPS y is the paper's z).

    ``virial`` holds, per particle, the pair part of (C1) before division by
    the area: W_ab = 1/2 sum_beta r_a f_b with r = r_alpha - r_beta and f the
    force on alpha (compression positive), columns (xx, yy, xy).
    """

    t: float
    x: np.ndarray
    z: np.ndarray
    u: np.ndarray
    w: np.ndarray
    radius: np.ndarray
    mass: np.ndarray
    virial: np.ndarray
    L: float
    H: float
    ids: np.ndarray | None = None


def pair_virial_from_stress_atom(s: np.ndarray) -> np.ndarray:
    """Per-particle pair part of (C1) from LAMMPS ``compute stress/atom NULL pair``.

    LAMMPS returns -1/2 sum_beta r_a f_b per atom (stress x volume, columns
    xx, yy, zz, xy, xz, yz); we return the compression-positive
    1/2 sum_beta r_a f_b in columns (xx, zz, xz) of the paper (LAMMPS y = z).
    """
    s = np.asarray(s, float)
    return -s[:, [0, 1, 3]]


class ShearCell:
    """A LAMMPS Lees-Edwards shear cell of appendix C.

    Args:
        phi0: requested mean packing fraction (sets L, appendix C)
        seed: random seed (placement); any positive int
        params: :class:`DEMParams`
    """

    def __init__(self, phi0: float, seed: int, params: DEMParams | None = None):
        self.params = params or DEMParams()
        self.phi0 = check_phi0(phi0)
        if not isinstance(seed, (int, np.integer)) or not 0 < seed < 900_000_000:
            raise ValueError(f"`seed` must be an integer in [1, 9e8); got {seed!r}")
        self.seed = int(seed)
        self.L = self.params.box_length(self.phi0)
        self.t = 0.0
        self.lmp = new_lammps()
        self._build()

    # ------------------------------------------------------------------ set-up
    def _cmd(self, text: str) -> None:
        self.lmp.commands_string(text)

    def _build(self) -> None:
        p = self.params
        n_per = p.n_particles // 5
        lines = [
            "units lj",
            "dimension 2",
            "atom_style sphere",
            "boundary p p p",
            "comm_modify vel yes",
            f"region box prism 0 {self.L!r} 0 {p.H!r} -0.5 0.5 0 0 0",
            "create_box 5 box",
        ]
        for k, d in enumerate(DIAMETER_CLASSES, start=1):
            lines += [
                f"create_atoms {k} random {n_per} {self.seed * 10 + k} NULL",
                f"set type {k} diameter {d!r}",
                f"set type {k} density/disc {p.rho!r}",
            ]
        lines += [
            "neighbor 0.3 bin",
            "neigh_modify delay 0 every 1 check yes",
            f"timestep {p.dt!r}",
            "compute s all stress/atom NULL pair",
            "compute p all reduce sum c_s[1] c_s[2] c_s[4]",
            "thermo_style custom step c_p[1] c_p[2] c_p[3]",
            "thermo 1000000000",
            "fix en all enforce2d",
        ]
        self._cmd("\n".join(lines))
        self._relax()
        self._cmd(f"pair_style granular\npair_coeff * * hooke {p.k_n!r} {p.eta_n!r} tangential "
                  f"linear_history {p.kt_over_kn * p.k_n!r} 0.0 {p.mu_p!r} damping velocity")
        self._start_shear()

    def _relax(self) -> None:
        """Remove the random-placement overlaps (appendix C: elastic, frictionless).

        The granular pair style carries no energy, so the overlaps are relaxed by
        energy minimisation with the equivalent elastic, frictionless Hookean
        repulsion E = k_n/2 (d_ij - r)^2 for r < d_ij (pair harmonic/cut), which
        leaves a force-free state with (near) zero overlap and zero kinetic energy.
        """
        p = self.params
        lines = ["pair_style harmonic/cut"]
        for i, di in enumerate(DIAMETER_CLASSES, start=1):
            for j, dj in enumerate(DIAMETER_CLASSES, start=1):
                if j >= i:
                    lines.append(f"pair_coeff {i} {j} {p.k_n / 2!r} {(di + dj) / 2!r}")
        lines += [
            "min_style fire",
            "minimize 0.0 1.0e-6 20000 200000",
            "velocity all set 0 0 0",
        ]
        self._cmd("\n".join(lines))

    def _start_shear(self) -> None:
        p = self.params
        self._cmd(
            "\n".join([
                f"variable vx atom {p.V0!r}*y/{p.H!r}",
                "velocity all set v_vx 0 0",
                "fix nv all nve/sphere disc",
                f"fix le all deform 1 xy erate {p.shear_rate!r} remap v flip yes",
                "reset_timestep 0",
                "run 0",
            ])
        )
        self.t = 0.0

    # --------------------------------------------------------------- dynamics
    def advance(self, duration: float) -> None:
        """Integrate for ``duration`` time units (rounded to whole steps)."""
        nsteps = max(1, int(round(duration / self.params.dt)))
        self._cmd(f"run {nsteps} post no")
        self.t += nsteps * self.params.dt

    def snapshot(self, with_stress: bool = True) -> Snapshot:
        """Copy the particle state; ``with_stress`` needs a completed run step."""
        lmp = self.lmp
        lmp_mod = __import__("lammps")
        n = lmp.get_natoms()
        x = np.array(lmp.numpy.extract_atom("x", nelem=n, dim=3), copy=True)
        v = np.array(lmp.numpy.extract_atom("v", nelem=n, dim=3), copy=True)
        r = np.array(lmp.numpy.extract_atom("radius", nelem=n), copy=True)
        m = np.array(lmp.numpy.extract_atom("rmass", nelem=n), copy=True)
        if with_stress:
            s = np.array(
                lmp.numpy.extract_compute("s", lmp_mod.LMP_STYLE_ATOM, lmp_mod.LMP_TYPE_ARRAY),
                copy=True,
            )[:n]
        else:
            s = np.full((n, 6), np.nan)
        ids = np.array(lmp.numpy.extract_atom("id", nelem=n), copy=True)
        return Snapshot(
            t=self.t, x=x[:, 0], z=x[:, 1], u=v[:, 0], w=v[:, 1], radius=r, mass=m,
            virial=pair_virial_from_stress_atom(s), L=self.L, H=self.params.H, ids=ids,
        )

    def set_velocities(self, vx: np.ndarray, vz: np.ndarray) -> None:
        """Replace per-particle velocities (same order as the last snapshot)."""
        lmp = self.lmp
        n = lmp.get_natoms()
        v = lmp.numpy.extract_atom("v", nelem=n, dim=3)
        v[:, 0] = vx
        v[:, 1] = vz
        v[:, 2] = 0.0

    def close(self) -> None:
        if self.lmp is not None:
            self.lmp.close()
            self.lmp = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
