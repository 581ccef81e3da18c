"""Snapshot files: py-pde's HDF5 ``FileStorage`` plus the true node positions, never half-written.

:class:`SnapshotFile` has py-pde's ``FileStorage`` write the frames into an HDF5 file held
in memory, and writes that file to the target when the run ends, successfully or not,
through :func:`icidr_pde.outputs.write_atomically` (whole or not at all). HDF5 itself never
writes to the disk: a full disk is then one OSError at the end (HDF5 crashes, SIGSEGV,
closing a file it could not flush), the run and its other outputs go on and
:attr:`SnapshotFile.error` says why. The frames are the snapshots the run keeps in memory
anyway; a run killed outright (SIGKILL) leaves the target as it was. The file holds
py-pde's ``times`` and ``data`` (frames x fields x nodes) and ``z``, the positions of the
unknowns: the py-pde grid stored by ``FileStorage`` is only a carrier for the Chebyshev
scheme, whose nodes are not uniform. :func:`read_snapshots` reads such a file.
"""

from __future__ import annotations

import io
import os
import re
from pathlib import Path

import numpy as np
from pde import FileStorage

from .outputs import write_atomically

__all__ = ["SnapshotFile", "read_snapshots"]


class _FileImage(io.BytesIO):
    """An HDF5 file in memory where py-pde's FileStorage expects a file name (h5py takes file
    objects; FileStorage asks the name for its `parent` folder and whether it `is_file` to
    delete)."""

    parent = Path(".")

    @staticmethod
    def is_file() -> bool:
        return False


class SnapshotFile:
    """Snapshots at `output_times` written to `path`, with the node positions `z`: a recorder
    of the run path (:func:`icidr_pde.api.run` with ``save=...``); `state` is the py-pde
    state whose layout (grid, fields) the file takes."""

    def __init__(self, path, z: np.ndarray, output_times, state):
        self.path = Path(path)
        self.z = np.asarray(z, dtype=float)
        self.output_times = np.asarray(output_times, dtype=float)
        self.error: str | None = None  # why the file could not be written
        self.written = False
        self.storage = FileStorage(os.devnull, write_mode="truncate", keep_opened=True)
        self.storage.filename = self.image = _FileImage()
        self._field = state.copy()
        self._guarded(self.storage.start_writing, self._field)

    def _guarded(self, write, *args) -> bool:
        """write(*args), or give up the file (h5py reports a full disk as OSError or RuntimeError)."""
        if self.error is not None:
            return False
        try:
            write(*args)
        except (OSError, RuntimeError) as err:
            self.fail(err)
            return False
        return True

    def record(self, t: float, data) -> None:
        self._field.data[...] = data
        self._guarded(lambda: self.storage.append(self._field, time=float(t)))

    def close(self, outcome=None) -> None:
        """The end of the run, however it ended: the frames so far are written."""
        if self._guarded(self.storage.end_writing):
            self.commit()

    def abandon(self) -> None:
        """A run that raised leaves an existing file as it was."""
        self.discard()

    def commit(self) -> None:
        """Add the node positions and write the file to `path` (idempotent)."""
        if self.written or self.error is not None:
            return
        import h5py

        self.storage.close()
        if not self.image.getbuffer().nbytes:  # the run ended before its first frame
            return
        with h5py.File(self.image, "a") as fh:
            if "z" not in fh:
                fh.create_dataset("z", data=self.z)
        data = self.image.getvalue()
        try:
            write_atomically(self.path, lambda fh: fh.write(data), "wb")
        except OSError as err:
            self.fail(err)
        self.written = True

    def fail(self, err) -> None:
        """Give up the file (the run goes on): remember why."""
        self.error = self.error or _why(err)
        self.discard()

    def discard(self) -> None:
        """Drop the frames (a run that did not start leaves the target alone)."""
        try:
            self.storage.close()
        except (OSError, RuntimeError):
            pass
        self.image = None


def _why(err) -> str:
    """The reason of an OSError, or of h5py's RuntimeError wrapping one ("... errno = 28 ...")."""
    if getattr(err, "strerror", None):
        return err.strerror
    found = re.search(r"errno = (\d+)", str(err))
    return os.strerror(int(found.group(1))) if found else str(err).splitlines()[0]


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
