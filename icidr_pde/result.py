"""The outcome of a shear-cell run: fields, time series, failure and cost."""

from __future__ import annotations

import json
import warnings
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from .cells import cell_of_result
from .outputs import write_atomically

__all__ = ["Result", "Fields"]

_MAX_W_RENAMED = ("Result.max_w is now Result.max_w_series (max|w| at the times max_w_t); the JSON's "
                  "'max_w' is max|w| at the requested times (Result.max_w_at_times())")


class Fields(NamedTuple):
    """phi, u, w of one state (a tuple: ``phi, u, w = res.final`` and ``res.final[2]`` work)."""

    phi: np.ndarray
    u: np.ndarray
    w: np.ndarray


@dataclass
class Result:
    """Everything a run computed, up to the end or up to its failure.

    Attributes:
        blew_up: True if the run failed before `t_end`
        t_star: last accepted time of a failed run (None otherwise)
        reason: why the run stopped: 'reached t_end', 'interrupted at t = ...' (Ctrl-C or
            SIGTERM; not a failure) or the failure
        t_final: time of the last state (t_end, t_star on failure, the time reached when
            interrupted: the engine's last accepted step, past the last output)
        z: positions of the unknowns
        times, phi, u, w: snapshots at the requested times that were reached
        final: :class:`Fields` (phi, u, w) at t_final (``res.final.w``)
        max_w_t, max_w_series: time series of max|w| over the nodes (``max_w`` is its old name,
            read with a DeprecationWarning: the JSON's ``max_w`` is max|w| at the requested times,
            :meth:`max_w_at_times`)
        last_times, last_states: the last states (up to 6, shape (n, 3, ...) as the snapshots)
            the run passed at its max|w| series times before t_final: what a failure grew from
        chi_t, chi_z, chi: chi (A18) at the stress points, if the scene asked for it
        mass_drift: relative change of the integral of phi between 0 and t_final
        wall_s, cpu_s: wall-clock and CPU time of the solve (kernel set-up, compile_s, excluded)
        n_steps, n_rhs, n_jac, n_lu: the integrator's counts (None where it has none)
        Nx, L, measures: 2-D runs only (N is then Nz): cells along x, period L, and per
            snapshot max_w, max_phi_dev (max|phi - phi0|) and l2_velocity
            (sqrt of the integral of (u - z/H)^2 + w^2 over the cell)
        not_written: outputs asked for that were not written, parameter -> why
            (e.g. {'save': 'No space left on device'}, {'movie': 'interrupted'})
        summary: on the ranks other than 0 of a run distributed by blocks, whose fields are rank 0's
            alone, rank 0's :meth:`to_dict` (None elsewhere: it is computed from the fields)
    """

    rheology: str
    scene: str
    discretization: str
    N: int
    t_end: float
    rtol: float
    atol: float
    method: str
    jacobian: str
    blew_up: bool
    t_star: float | None
    reason: str
    t_final: float
    z: np.ndarray
    times: np.ndarray
    time_labels: list[str]
    phi: np.ndarray
    u: np.ndarray
    w: np.ndarray
    final: tuple[np.ndarray, np.ndarray, np.ndarray]
    max_w_t: np.ndarray
    max_w_series: np.ndarray
    mass_drift: float
    wall_s: float
    compile_s: float
    n_steps: int
    n_rhs: int
    n_jac: int
    n_lu: int | None = None
    cpu_s: float | None = None
    requested_times: list[str] = field(default_factory=list)
    chi_t: np.ndarray | None = None
    chi_z: np.ndarray | None = None
    chi: np.ndarray | None = None
    scene_params: dict = field(default_factory=dict)
    material: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)
    Nx: int | None = None
    L: float | None = None
    measures: list | None = None
    not_written: dict = field(default_factory=dict)
    last_times: np.ndarray = field(default_factory=lambda: np.empty(0))
    last_states: np.ndarray | None = None
    summary: dict | None = None

    @property
    def max_w(self) -> np.ndarray:
        """The old name of :attr:`max_w_series`, kept with a DeprecationWarning: ``max_w`` of the
        JSON (:meth:`to_dict`) is a different quantity, max|w| at the requested times."""
        warnings.warn(_MAX_W_RENAMED, DeprecationWarning, stacklevel=2)
        return self.max_w_series

    @max_w.setter
    def max_w(self, value) -> None:
        warnings.warn(_MAX_W_RENAMED, DeprecationWarning, stacklevel=2)
        self.max_w_series = value

    def max_w_at_times(self) -> dict[str, float]:
        """max|w| at each requested time reached (label as requested -> value)."""
        return {label: float(np.max(np.abs(w))) for label, w in zip(self.time_labels, self.w)}

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (the CLI's --json contract)."""
        if self.summary is not None:
            return dict(self.summary)
        out = {
            "rheology": self.rheology,
            "scene": self.scene,
            "discretization": self.discretization,
            "N": self.N,
            "t_end": self.t_end,
            "rtol": self.rtol,
            "atol": self.atol,
            "method": self.method,
            "jacobian": self.jacobian,
            "blew_up": self.blew_up,
            "t_star": self.t_star,
            "reason": self.reason,
            "t_final": self.t_final,
            "max_w": self.max_w_at_times(),
            "mass_drift": self.mass_drift,
            "wall_s": self.wall_s,
            "compile_s": self.compile_s,
            "cpu_s": self.cpu_s,
            "n_steps": self.n_steps,
            "n_rhs": self.n_rhs,
            "n_jac": self.n_jac,
            "n_lu": self.n_lu,
            "scene_params": self.scene_params,
            "material": self.material,
            "settings": self.settings,
        }
        if self.not_written:
            out["not_written"] = dict(self.not_written)
        out.update(cell_of_result(self).result_summary(self))  # what the run's cell adds
        return out

    def plot(self, path=None):
        """The figure of ``icidr-pde run --plot``: snapshots, max|w|(t) and, for a failed run,
        the last states before t* and the state at t* (:func:`icidr_pde.plotting.plot_result`)."""
        from .plotting import plot_result

        return plot_result(self, path)

    @property
    def interrupted(self) -> bool:
        """True if the run was stopped by the user (Ctrl-C, SIGTERM) before t_end."""
        return self.reason.startswith("interrupted")

    def save_json(self, path) -> None:
        """Write :meth:`to_dict` as JSON; the file appears complete or not at all."""
        text = json.dumps(self.to_dict(), indent=2)
        write_atomically(path, lambda fh: fh.write(text))

    def __repr__(self) -> str:
        if self.blew_up:
            state = f"failed at t*={self.t_star:.6g} ({self.reason})"
        elif self.interrupted:
            state = self.reason
        else:
            state = "reached t_end"
        steps = f"{self.n_steps} steps" if self.n_steps is not None else f"{self.n_rhs} RHS evaluations"
        return (f"Result({self.rheology}, {self.scene}, {self.discretization} N={self.N}: {state}; "
                f"{steps}, {self.wall_s:.2f} s)")
