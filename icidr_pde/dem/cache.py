"""Per-run result cache (one .npz per DEM run) so plots can be remade without LAMMPS."""

from __future__ import annotations

import hashlib
import os
from dataclasses import asdict
from pathlib import Path

import numpy as np

from ..outputs import replacing



def default_cache_dir() -> Path:
    """Per-user cache of DEM runs, outside any source tree: $ICIDR_PDE_CACHE, else
    $XDG_CACHE_HOME/icidr-pde/dem, else ~/.cache/icidr-pde/dem."""
    env = os.environ.get("ICIDR_PDE_CACHE")
    if env:
        return Path(env)
    root = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(root) / "icidr-pde" / "dem"


DEFAULT_CACHE = default_cache_dir()


def run_seed(base_seed: int, repeat: int, phi0: float) -> int:
    """Independent, reproducible seed of one run (1 <= seed < 1e8)."""
    ss = np.random.SeedSequence([int(base_seed), int(repeat), int(round(phi0 * 10000))])
    return int(ss.generate_state(1)[0] % 99_999_999) + 1


def run_key(phi0, seed, params, protocol) -> str:
    h = hashlib.sha1(repr((asdict(params), asdict(protocol))).encode()).hexdigest()[:8]
    return f"phi{phi0:.4f}_N{params.n_particles}_s{seed}_{h}"


def load(cache_dir, key):
    path = Path(cache_dir) / f"{key}.npz"
    if not path.exists():
        return None
    with np.load(path, allow_pickle=False) as f:
        return {k: (f[k].item() if f[k].ndim == 0 else f[k]) for k in f.files}


def save(cache_dir, key, result: dict) -> Path:
    cache_dir = Path(cache_dir)
    cache_dir.mkdir(parents=True, exist_ok=True)
    path = cache_dir / f"{key}.npz"
    with replacing(path) as tmp:
        np.savez_compressed(tmp, **{k: np.asarray(v) for k, v in result.items()})
    return path
