"""Snapshot files: py-pde's HDF5 ``FileStorage`` plus the true node positions, never half-written.

:class:`SnapshotFile` writes the frames into a temporary file beside the target, closing
the file after every frame (py-pde's ``keep_opened=False``, so every frame written is on
disk and the file is consistent), and moves it over the target when the run ends,
successfully or not. A run that is killed outright leaves the target as it was and the
frames written so far in ``.NAME.partial``. The file holds py-pde's ``times`` and
``data`` (frames x fields x nodes) and ``z``, the positions of the unknowns: the py-pde
grid stored by ``FileStorage`` is only a carrier for the Chebyshev scheme, whose nodes
are not uniform. :func:`read_snapshots` reads such a file.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from pde import FileStorage
from pde.storage.base import StorageTracker

__all__ = ["SnapshotFile", "read_snapshots"]


class SnapshotFile:
    """Snapshots at `interrupts` written to `path`, with the node positions `z`."""

    def __init__(self, path, z: np.ndarray, interrupts):
        self.path = Path(path)
        self.partial = self.path.with_name(f".{self.path.name}.partial")
        self.z = np.asarray(z, dtype=float)
        self.storage = FileStorage(self.partial, write_mode="truncate", keep_opened=False)
        self._tracker = _FinalizingTracker(self, interrupts)

    def tracker(self) -> StorageTracker:
        return self._tracker

    def commit(self) -> None:
        """Add the node positions and move the file into place (idempotent)."""
        if not self.partial.exists():
            return
        import h5py

        self.storage.close()
        with h5py.File(self.partial, "a") as fh:
            if "z" not in fh:
                fh.create_dataset("z", data=self.z)
        os.replace(self.partial, self.path)

    def discard(self) -> None:
        """Remove the temporary file (a run that did not start leaves the target alone)."""
        self.storage.close()
        if self.partial.exists():
            self.partial.unlink()


class _FinalizingTracker(StorageTracker):
    def __init__(self, snapshot_file: SnapshotFile, interrupts):
        super().__init__(snapshot_file.storage, interrupts=interrupts)
        self.snapshot_file = snapshot_file

    def finalize(self, info=None) -> None:
        storage = self.storage
        if storage._is_writing and storage._file is None:
            # py-pde 0.59 writes the closing attributes into the file it closed after the
            # last frame (keep_opened=False): open it again first
            storage._open("appending")
        super().finalize(info)
        self.snapshot_file.commit()


def read_snapshots(path) -> dict[str, np.ndarray]:
    """Read a file written by ``run(..., save=path)`` or ``icidr-pde run --save path``.

    Returns z (positions of the unknowns: the cell centres for 'fd', the collocation
    points for 'cheb'), times, and phi, u, w, each of shape (len(times), len(z)).
    """
    import h5py

    with h5py.File(path, "r") as fh:
        data = np.array(fh["data"])
        out = {"z": np.array(fh["z"]), "times": np.array(fh["times"])}
    out.update(phi=data[:, 0], u=data[:, 1], w=data[:, 2])
    return out
