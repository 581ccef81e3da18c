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


PREPARATIONS = ("minimize", "rescale")
#: kinetic temperature (per degree of freedom, m V0^2 units) and duration of the
#: appendix-C "rescale" preparation; equipartition gives overlaps ~ sqrt(2 T / k_n)
RESCALE_TEMPERATURE = 1.0e-3
RESCALE_TIME = 20.0


class ShearCell:
    """A LAMMPS Lees-Edwards shear cell of appendix C.

    Args:
        phi0: requested mean packing fraction (sets L, appendix C)
        seed: random seed (placement); any positive int
        params: :class:`DEMParams`
        preparation: overlap removal before shearing, 'minimize' (FIRE on the
            equivalent elastic frictionless repulsion) or 'rescale' (appendix C:
            elastic frictionless dynamics with the kinetic energy rescaled to a
            small constant, see :data:`RESCALE_TEMPERATURE`, :data:`RESCALE_TIME`)
        restart: a file written by :meth:`write_restart`; the cell continues from
            it (positions, velocities, spins, contact history, box tilt) and
            ``seed``/``preparation`` are ignored
    """

    def __init__(self, phi0: float, seed: int, params: DEMParams | None = None,
                 preparation: str = "minimize", restart=None):
        self.params = params or DEMParams()
        self.phi0 = check_phi0(phi0)
        if not isinstance(seed, (int, np.integer)) or not 0 < seed < 900_000_000:
            raise ValueError(f"`seed` must be an integer in [1, 9e8); got {seed!r}")
        if preparation not in PREPARATIONS:
            raise ValueError(f"`preparation` must be one of {PREPARATIONS}; got {preparation!r}")
        self.seed = int(seed)
        self.preparation = preparation
        self.L = self.params.box_length(self.phi0)
        self.t = 0.0
        self.lmp = new_lammps()
        if restart is None:
            self._build()
        else:
            self._from_restart(str(restart))

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
        lines += self._run_settings()
        self._cmd("\n".join(lines))
        if self.preparation == "minimize":
            self._relax()
        else:
            self._relax_rescale()
        self._cmd(self._contact_commands())
        self._start_shear()

    def _run_settings(self) -> list[str]:
        """Neighbour lists, time step, the pair-stress reduction and the 2-D constraint,
        the same for a new cell and for one continued from a restart file."""
        return [
            "neighbor 0.3 bin",
            "neigh_modify delay 0 every 1 check yes",
            f"timestep {self.params.dt!r}",
            "compute s all stress/atom NULL pair",
            "compute p all reduce sum c_s[1] c_s[2] c_s[4]",
            "thermo_style custom step c_p[1] c_p[2] c_p[3]",
            "thermo 1000000000",
            "fix en all enforce2d",
        ]

    def _contact_commands(self) -> str:
        """The appendix-C frictional spring-dashpot contact (pair granular)."""
        p = self.params
        return (f"pair_style granular\npair_coeff * * hooke {p.k_n!r} {p.eta_n!r} tangential "
                f"linear_history {p.kt_over_kn * p.k_n!r} 0.0 {p.mu_p!r} damping velocity")

    def _from_restart(self, path: str) -> None:
        """Continue a sheared cell from a restart file (pair style and contact
        history are stored in it; the fixes are re-created with the same IDs)."""
        p = self.params
        self._cmd("\n".join([
            f"read_restart {path}",
            # the restored granular style finds no contacts (its radius-based
            # cutoff is not restored: 0 neighbours); re-specifying the same style
            # keeps its instance and the contact-history fix
            self._contact_commands(),
            "comm_modify vel yes",
            *self._run_settings(),
            "fix nv all nve/sphere disc",
            f"fix le all deform 1 xy erate {p.shear_rate!r} remap v flip yes",
            "run 0",
        ]))
        self.t = 0.0

    def write_restart(self, path) -> None:
        """Write the full state (incl. contact history) for :class:`ShearCell` ``restart=``."""
        self._cmd(f"write_restart {path}")

    def set_timestep(self, dt: float) -> None:
        if not (math.isfinite(dt) and dt > 0):
            raise ValueError(f"`dt` must be > 0; got {dt}")
        self._cmd(f"timestep {dt!r}")
        self._dt = dt

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

    def _relax_rescale(self) -> None:
        """Appendix C: elastic, frictionless disks whose total kinetic energy is
        rescaled to a small constant every step, until the overlaps have relaxed."""
        p = self.params
        nsteps = int(round(RESCALE_TIME / p.dt))
        T = RESCALE_TEMPERATURE
        self._cmd("\n".join([
            "pair_style granular",
            f"pair_coeff * * hooke {p.k_n!r} 0.0 tangential linear_nohistory 0.0 0.0",
            "fix nv0 all nve/sphere disc",
            f"fix kr all temp/rescale 1 {T!r} {T!r} 0.0 1.0",
            f"run {nsteps} post no",
            "unfix kr",
            "unfix nv0",
            "velocity all set 0 0 0",
            "reset_timestep 0",
        ]))

    def max_overlap(self) -> float:
        """Largest overlap r_i + r_j - distance (units of d) by brute force; valid before shearing (zero tilt)."""
        s = self.snapshot(with_stress=False)
        x, z, r = s.x, np.mod(s.z, s.H), s.radius
        worst = 0.0
        for i in range(x.size - 1):
            dx = x[i + 1:] - x[i]
            dz = z[i + 1:] - z[i]
            dz -= s.H * np.round(dz / s.H)
            dx -= s.L * np.round(dx / s.L)   # tilt ignored: only called before shearing
            ov = r[i] + r[i + 1:] - np.hypot(dx, dz)
            if ov.size:
                worst = max(worst, float(ov.max()))
        return worst

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
        dt = getattr(self, "_dt", self.params.dt)
        nsteps = max(1, int(round(duration / dt)))
        self._cmd(f"run {nsteps} post no")
        self.t += nsteps * dt

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
