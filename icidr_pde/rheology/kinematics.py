"""Kinematics adapters: how a flow's strain rates reach the invariant laws.

A rheology is a map (phi, div u, ||S||) -> (p, c) with tau = c S, the alignment law (2.6)
(:class:`~icidr_pde.rheology.base.Rheology`). A kinematics adapter names the strain-rate
inputs of one geometry, expresses div u and ||S|| in them through the velocity gradient,
(2.4)-(2.5), and lists the stress components the discretization needs. Kernels and their
Jacobians in those inputs are generated per (law, adapter) (:mod:`.codegen`).

* :data:`INVARIANTS`: inputs (div_u, norm_S), outputs (p, c) -- the law itself;
* :data:`SHEAR_CELL`: the 1-D cell, velocity (u(z), w(z)): inputs (u_z, w_z), so that
  div u = w_z and ||S||^2 = (u_z^2 + w_z^2)/4 (3.4)-(3.5); outputs (p, tau_xz, tau_zz);
* :data:`PLANE_FLOW`: 2-D flow (u(x, z), w(x, z)): inputs (u_x, u_z, w_x, w_z), outputs
  (p, tau_xx, tau_xz, tau_zz).

A new geometry (e.g. 2-D, inputs u_x, u_z, w_x, w_z) is one :class:`Kinematics` subclass
giving its velocity gradient and the components of S it needs.
"""

from __future__ import annotations

__all__ = ["Kinematics", "Invariants", "ShearCell", "PlaneFlow", "INVARIANTS", "SHEAR_CELL", "PLANE_FLOW",
           "strain_rate"]


def strain_rate(grad_u):
    """div u, the deviatoric strain rate S and ||S|| of a velocity gradient, (2.4)-(2.5).

    `grad_u` is a square sympy Matrix with grad_u[i, j] = d_j u_i; D = (grad_u + grad_u^T)/2,
    S = D - (tr D/dim) Id, ||T|| = sqrt(tr(T^2)/2).
    """
    import sympy as sp

    n = grad_u.shape[0]
    D = (grad_u + grad_u.T) / 2
    div = sp.simplify(D.trace())
    S = D - div / n * sp.eye(n)
    norm = sp.sqrt(sp.factor(sp.expand((S * S).trace() / 2)))
    return div, S, norm


class Kinematics:
    """Strain-rate inputs of a geometry and the stress components it needs."""

    name: str = ""
    rates: tuple[str, ...] = ()
    outputs: tuple[str, ...] = ()

    def rate_symbols(self) -> tuple:
        import sympy as sp

        return tuple(sp.Symbol(r, real=True) for r in self.rates)

    def invariants(self, rates) -> tuple:
        """(div u, ||S||) in terms of the rate symbols."""
        raise NotImplementedError

    def stresses(self, p, c, rates) -> tuple:
        """The output components from the law's (p, c)."""
        raise NotImplementedError

    def __repr__(self):
        return f"<kinematics {self.name}: {self.rates} -> {self.outputs}>"


class Invariants(Kinematics):
    """The law itself: inputs (div u, ||S||), outputs (p, c)."""

    name = "invariants"
    rates = ("div_u", "norm_S")
    outputs = ("p", "c")

    def rate_symbols(self):
        from .symbols import div_u, norm_S

        return div_u, norm_S

    def invariants(self, rates):
        return tuple(rates)

    def stresses(self, p, c, rates):
        return p, c


class ShearCell(Kinematics):
    """Velocity (u(z), w(z)): grad u = [[0, u_z], [0, w_z]] in (x, z), (3.4)."""

    name = "shear_cell"
    rates = ("u_z", "w_z")
    outputs = ("p", "tau_xz", "tau_zz")

    def _tensors(self, rates):
        import sympy as sp

        uz, wz = rates
        return strain_rate(sp.Matrix([[0, uz], [0, wz]]))

    def invariants(self, rates):
        div, _, norm = self._tensors(rates)
        return div, norm

    def stresses(self, p, c, rates):
        _, S, _ = self._tensors(rates)
        return p, c * S[0, 1], c * S[1, 1]


INVARIANTS = Invariants()
SHEAR_CELL = ShearCell()


class PlaneFlow(Kinematics):
    """Velocity (u(x, z), w(x, z)): the full gradient [[u_x, u_z], [w_x, w_z]] (2.4)-(2.5).

    Outputs the stress components of a 2-D flow, p and tau = c S (tau_zx = tau_xz); with
    u_x = w_x = 0 the invariants are those of :class:`ShearCell`.
    """

    name = "plane_flow"
    rates = ("u_x", "u_z", "w_x", "w_z")
    outputs = ("p", "tau_xx", "tau_xz", "tau_zz")

    def _tensors(self, rates):
        import sympy as sp

        ux, uz, wx, wz = rates
        return strain_rate(sp.Matrix([[ux, uz], [wx, wz]]))

    def invariants(self, rates):
        div, _, norm = self._tensors(rates)
        return div, norm

    def stresses(self, p, c, rates):
        _, S, _ = self._tensors(rates)
        return p, c * S[0, 0], c * S[0, 1], c * S[1, 1]


PLANE_FLOW = PlaneFlow()
