"""Snapshot files: py-pde's HDF5 ``FileStorage`` plus the true node positions, never half-written.

:class:`SnapshotFile` writes the frames into a temporary file beside the target, closing
the file after every frame (py-pde's ``keep_opened=False``, so every frame written is on
disk and the file is consistent), and moves it over the target when the run ends,
successfully or not. A run that is killed outright leaves the target as it was and the
frames written so far in a temporary ``.NAME.*.partial.h5`` beside it
(:mod:`icidr_pde.outputs`). A frame that cannot be written (a full disk) stops the file,
not the run: :attr:`SnapshotFile.error` says why and the temporary file is removed. The file holds py-pde's ``times`` and
``data`` (frames x fields x nodes) and ``z``, the positions of the unknowns: the py-pde
grid stored by ``FileStorage`` is only a carrier for the Chebyshev scheme, whose nodes
are not uniform. :func:`read_snapshots` reads such a file.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from pde import FileStorage
from pde.storage.base import StorageTracker

from .outputs import discard, install, temporary_beside

__all__ = ["SnapshotFile", "read_snapshots"]


class SnapshotFile:
    """Snapshots at `interrupts` written to `path`, with the node positions `z`."""

    def __init__(self, path, z: np.ndarray, interrupts):
        self.path = Path(path)
        self.partial = temporary_beside(self.path, ".h5")
        self.z = np.asarray(z, dtype=float)
        self.error: str | None = None  # why the file could not be written
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
        try:
            with h5py.File(self.partial, "a") as fh:
                if "z" not in fh:
                    fh.create_dataset("z", data=self.z)
            install(self.partial, self.path)
        except (OSError, RuntimeError) as err:
            self.fail(err)

    def fail(self, err) -> None:
        """Give up the file (the run goes on): remember why, remove the temporary file."""
        self.error = self.error or (err.strerror if getattr(err, "strerror", None) else str(err))
        self.discard()

    def discard(self) -> None:
        """Remove the temporary file (a run that did not start leaves the target alone)."""
        try:
            self.storage.close()
        except (OSError, RuntimeError):
            pass
        discard(self.partial)


class _FinalizingTracker(StorageTracker):
    def __init__(self, snapshot_file: SnapshotFile, interrupts):
        super().__init__(snapshot_file.storage, interrupts=interrupts)
        self.snapshot_file = snapshot_file

    def initialize(self, field, info=None) -> float:
        t_first = super(StorageTracker, self).initialize(field, info)  # the interrupts only
        try:
            self.storage.start_writing(self._transform(field, t_first), info)
        except (OSError, RuntimeError) as err:
            self.snapshot_file.fail(err)
        return t_first

    def handle(self, field, t: float) -> None:
        if self.snapshot_file.error is not None:
            return
        try:
            super().handle(field, t)
        except (OSError, RuntimeError) as err:  # h5py reports a full disk as either
            self.snapshot_file.fail(err)

    def finalize(self, info=None) -> None:
        if self.snapshot_file.error is not None:
            return
        storage = self.storage
        try:
            if storage._is_writing and storage._file is None:
                # py-pde 0.59 writes the closing attributes into the file it closed after the
                # last frame (keep_opened=False): open it again first
                storage._open("appending")
            super().finalize(info)
        except (OSError, RuntimeError) as err:
            self.snapshot_file.fail(err)
            return
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
