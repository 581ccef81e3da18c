"""Sympy-backed well-posedness toolkit for the 1-D shear cell (Schaeffer et al. 2019, JFM 874).

Modules (one concept each):

* :mod:`stability.symbols` -- shared sympy symbols;
* :mod:`stability.rheologies` -- symbolic p, tau_xz, tau_zz of mu(I),Phi(I) and iCIDR;
* :mod:`stability.cidr` -- section 4: conditions (4.3)-(4.5), derivation of (4.8), (4.9)-(4.14);
* :mod:`stability.linearize` -- general (A2)-(A9) linearisation and the -C/B limit;
* :mod:`stability.mui` -- appendix A for mu(I),Phi(I): (A10)-(A18), chi;
* :mod:`stability.icidr` -- section 5: (5.1)-(5.6), Gamma and the well-posedness proof;
* :mod:`stability.dissipation` -- appendix B: (B1)-(B15), convexity of psi;
* :mod:`stability.numeric` -- compiled symbols, item-7 numbers;
* :mod:`stability.growth` -- numerical cross-checks (eigenvalues, time integration, FD spectrum);
* :mod:`stability.linear2d` -- the 2-D cell's equations linearized about an x-independent state, per x-wave number;
* :mod:`stability.plane`, :mod:`stability.directional` -- plane waves in the x-z plane (2-D conventions);
* :mod:`stability.spatial` -- plane waves in every direction of space (3-D conventions, S = D - div u/3 I);
* :mod:`stability.incompressible` -- incompressible mu(I) in 2-D: Barker et al. (2015)'s criterion, derived;
* :mod:`stability.workbench` -- the rheology workbench's report of a law;
* :mod:`stability.report` -- the table of ``icidr-pde verify`` (its command line: :mod:`icidr_pde.cli`).
"""

__all__ = ["symbols", "rheologies", "cidr", "linearize", "mui", "icidr", "dissipation", "numeric", "growth",
           "report", "cli"]
