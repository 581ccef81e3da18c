"""Rheologies on invariants: (phi, div u, ||S||) -> (p, c) with tau = c S, written once.

Both rheologies of the paper obey the alignment law (2.6), tau = (||tau||/||S||) S, so a
rheology is two scalar functions of the invariants: the pressure p and the coefficient
c = ||tau||/||S||. A subclass writes them once, as sympy, in :meth:`Rheology.law` in terms
of M = M(phi) = mu(Psi(phi)) and Psi = Psi(phi) of its :class:`Material`; everything numeric
(kernels for any geometry, their Jacobians) is generated from that definition
(:mod:`icidr_pde.rheology.codegen`). Non-dimensional with the scalings (3.12), d = rho_* = 1;
every law here carries the Bagnold scaling, dimensional stresses are rho_* d^2 times these.

A subclass with a ``name`` registers itself in :data:`~.registry.RHEOLOGIES` (one class in one
file); :func:`~.direct.define_rheology` builds and registers one at run time from sympy expressions.
"""

from __future__ import annotations

import numpy as np

from ..validation import ParameterError

from .errors import LawError
from .kinematics import INVARIANTS, SHEAR_CELL, Kinematics
from .material import Material
from .registry import RHEOLOGIES

__all__ = ["Rheology", "RHEOLOGIES", "LawError", "chi", "ill_defined", "sample_states"]


class Rheology:
    """A constitutive law on invariants, plus the kernels generated from it.

    Subclasses set ``name`` and ``label`` and implement :meth:`law`.

    Args:
        material: laws and parameters (default :class:`Material`\\ (): Table 1)
    """

    name: str = ""
    label: str = ""

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls.__dict__.get("name"):
            RHEOLOGIES[cls.name] = cls

    def __init__(self, material: Material | None = None):
        self.material = type(self).default_material() if material is None else material
        if not isinstance(self.material, Material):
            raise TypeError("`material` must be an icidr_pde.rheology.Material")

    @classmethod
    def default_material(cls) -> Material:
        """The material used when none is given (Table 1; a law may ship its own)."""
        return Material()

    def __repr__(self) -> str:
        return f"{self.__class__.__name__}({self.material!r})"

    def __eq__(self, other):
        return type(other) is type(self) and other.material == self.material

    def __hash__(self):
        return hash((type(self), self.material))

    # --- the definition ---------------------------------------------------------------

    def law(self, phi, div_u, norm_S, M, Psi, prm, stable: bool = False):
        """(p, c) as sympy expressions; M, Psi are M(phi) and Psi(phi).

        `prm` maps the material parameter names to their values or symbols (for laws that
        use a parameter directly, e.g. phi_c). `stable` asks for a form that is free of cancellation in floating point (it must
        be the same function); the default form is the one to analyse symbolically.
        """
        raise NotImplementedError

    def symbolic_stress(self, phi, div_u, norm_S, *, symbolic: bool = False, stable: bool = False):
        """(p, c) with tau = c S, as sympy expressions of the given arguments.

        Material parameters are exact numbers, or their symbols with ``symbolic=True``
        (:data:`~icidr_pde.rheology.symbols.MATERIAL_SYMBOLS`); `stable` as for :meth:`law`.
        """
        M = self.material.symbolic_M(phi, symbolic)
        Psi = self.material.symbolic_Psi(phi, symbolic)
        return self.law(phi, div_u, norm_S, M, Psi, self.material.values(symbolic), stable=stable)

    @classmethod
    def definition_key(cls) -> str:
        """Text the generated kernels depend on (the source of the defining module)."""
        from .codegen import _module_source

        return _module_source(cls.__module__)

    # --- generated kernels ------------------------------------------------------------

    def kernels(self, kinematics: Kinematics = SHEAR_CELL):
        """The generated kernel module of this law for `kinematics` (see :mod:`.codegen`).

        It has ``stress(phi, *rates, params)`` and ``stress_jacobian`` (scalar, numba,
        cached on disk), ``stress_array``/``stress_jacobian_array`` (numba loops over 1-D
        arrays) and ``stress_numpy``/``stress_jacobian_numpy`` (plain numpy, no compilation);
        ``params`` is ``material.params``. The Jacobian lists d(output k)/d(phi, rates...)
        output by output.
        """
        from .codegen import law_kernels

        return law_kernels(self, kinematics)

    #: p and tau are homogeneous of degree 2 in the strain rate (rate-independent laws)
    rate_homogeneous: bool = False
    #: a law defined at run time (a law file, :func:`define_rheology`): checked before it is run,
    #: and it may not take a built-in law's name
    defined_at_run_time: bool = False

    def check_runnable(self) -> None:
        """Raise LawError (naming a state) if a law defined at run time has p or c not finite, or
        p < 0, on the sample of :func:`sample_states` (an ill-defined law: nothing to run).

        The built-in laws are not evaluated here (a test checks them), so running them costs no sympy work.
        """
        if not self.defined_at_run_time:
            return

        for what, state, value in ill_defined(self):
            if what != "c < 0":   # c < 0 (negative dissipation) is reported by `law check`, as Y < 0 is
                raise LawError(self.name, f"{what} (the law is ill-defined; it needs finite p >= 0 and c), "
                                          "so it cannot be run", state, f"value {value:.6g}")

    def _inputs(self, phi, uz, wz):
        phi, uz, wz = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (phi, uz, wz)))
        self.material.check_phi(phi)
        for name, value in (("uz", uz), ("wz", wz)):
            if not np.all(np.isfinite(value)):
                raise ValueError(f"`{name}` must be finite")
        return phi, uz, wz

    def stress(self, phi, uz, wz):
        """Shear-cell (p, tau_xz, tau_zz) for arrays of phi in the inertial range, u_z, w_z.

        For a rate-independent law (``rate_homogeneous``: p and tau of degree 2 in the
        strain rate) the kernel is evaluated at the rates scaled by a power of two to order 1
        and the result scaled back exactly, so no intermediate overflows or underflows; a
        result outside the normal float range (|rates| beyond ~1e150, or so small that p
        underflows) is refused by name instead of returned as nan, inf or a spurious 0.
        """
        phi, uz, wz = self._inputs(phi, uz, wz)
        kernel = self.kernels().stress_numpy
        if not self.rate_homogeneous:
            return self._in_float_range(kernel(phi, uz, wz, self.material.params), uz, wz)
        _, e = np.frexp(np.maximum(np.abs(uz), np.abs(wz)))
        unit = np.ldexp(1.0, e)
        scaled = kernel(phi, uz / unit, wz / unit, self.material.params)
        with np.errstate(over="ignore", under="ignore"):  # judged by _in_float_range
            out = tuple(np.ldexp(x, 2 * e) for x in scaled)
        return self._in_float_range(out, uz, wz)

    def _in_float_range(self, out, uz, wz):
        p = out[0]
        moving = (uz != 0) | (wz != 0)
        bad = ~np.all([np.isfinite(x) for x in out], axis=0)
        if self.rate_homogeneous:
            bad |= moving & (np.abs(p) < np.finfo(float).tiny)
        if np.any(bad):
            i = np.flatnonzero(np.ravel(bad))[0]
            u, w = float(np.ravel(uz)[i]), float(np.ravel(wz)[i])
            raise ParameterError(f"strain rates u_z = {u:g}, w_z = {w:g} give a pressure outside the "
                                 f"float range (|p| in [{np.finfo(float).tiny:.3g}, {np.finfo(float).max:.3g}]); "
                                 "rescale the problem")
        return out

    def stress_jacobian(self, phi, uz, wz):
        """The nine partial derivatives of (p, tau_xz, tau_zz) by (phi, u_z, w_z)."""
        phi, uz, wz = self._inputs(phi, uz, wz)
        return self.kernels().stress_jacobian_numpy(phi, uz, wz, self.material.params)

    def invariant_stress(self, phi, div_u, norm_S):
        """(p, c) of the law for arrays of phi, div u and ||S|| >= 0."""
        phi = self.material.check_phi(phi)
        return self.kernels(INVARIANTS).stress_numpy(phi, np.asarray(div_u, float),
                                                     np.asarray(norm_S, float), self.material.params)

    def chi(self, phi, uz, wz):
        """chi of (A18) at these states (the ill-posedness indicator of mu(I), see :func:`chi`)."""
        return chi(phi, uz, wz, self.material)


def chi(phi, uz, wz, material: Material | None = None) -> np.ndarray:
    """Ill-posedness indicator chi = w_z/|u_z| - M/sqrt(1 - M^2) of (A18) (> 0: ill-posed).

    Where u_z = 0 the ratio is +inf for w_z > 0 (there (A16) holds: ill-posed, as the paper
    says) and -inf for w_z < 0. At u_z = w_z = 0 chi is nan: Gamma = 0 there, the symbol is
    degenerate and neither (A16) nor (A17) holds. `material` defaults to Table 1.
    """
    material = Material() if material is None else material
    phi = material.check_phi(phi)
    uz, wz = np.asarray(uz, float), np.asarray(wz, float)
    for name, value in (("uz", uz), ("wz", wz)):
        if not np.all(np.isfinite(value)):
            raise ValueError(f"`{name}` must be finite (any real number); got {value!r}")
    return chi_of_M(material.M(phi), uz, wz)


def chi_of_M(M, uz, wz) -> np.ndarray:
    """chi of (A18) from M(phi) and the strain rates (see :func:`chi`; no checks)."""
    au = np.abs(uz)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(au > 0, wz / np.where(au > 0, au, 1.0), np.sign(wz) * np.inf)
    return ratio - M / np.sqrt(1.0 - M * M)


def sample_states(phi_range, n_phi=9, n_div=13, n_S=7):
    """The sample of (phi, div u, ||S||) on which roots and closed forms are checked.

    phi uniform inside `phi_range` (ends excluded), div u in [-2, 2] (0 included),
    ||S|| log-uniform in [1e-3, 10]. Returns three flat arrays.
    """
    lo, hi = phi_range
    phis = np.linspace(lo, hi, n_phi + 2)[1:-1]
    divs = np.linspace(-2.0, 2.0, n_div)
    Ss = np.logspace(-3, 1, n_S)
    P, D, S = np.meshgrid(phis, divs, Ss, indexing="ij")
    return P.ravel(), D.ravel(), S.ravel()


def ill_defined(rheology) -> list[tuple[str, dict, float]]:
    """Where p or c (tau = c S) is not finite, or negative, on the sample of :func:`sample_states`.

    A list of (what, state, value), the first state of each failure ("p is not finite",
    "c is not finite", "p < 0", "c < 0"); empty for a law defined everywhere on the sample.
    A CIDR law's states without a positive solution for p (:meth:`~.cidr.CIDRLaw.inadmissible`) are
    left out: there is no p there to judge.
    """
    phis, divs, Ss = sample_states(rheology.material.phi_range)
    skip = rheology.inadmissible() if hasattr(rheology, "inadmissible") else np.zeros(phis.shape, dtype=bool)
    with np.errstate(all="ignore"):
        p, c = (np.broadcast_to(np.asarray(v, dtype=float), phis.shape)
                for v in rheology.invariant_stress(phis, divs, Ss))
    out = []
    for what, bad, v in (("p is not finite", ~np.isfinite(p), p), ("c is not finite", ~np.isfinite(c), c),
                         ("p < 0", p < 0, p), ("c < 0", c < 0, c)):
        bad = bad & ~skip
        if np.any(bad):
            i = int(np.argmax(bad))
            out.append((what, {"phi": float(phis[i]), "div_u": float(divs[i]), "norm_S": float(Ss[i])}, float(v[i])))
    return out
