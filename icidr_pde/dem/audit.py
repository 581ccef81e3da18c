"""Protocol audit of the fig 8 transient (issue: why fig 8(d) disagrees).

Each *factor* is one change of the section-6 protocol against the baseline
(appendix C as run here: FIRE preparation, 30 time units of shear, (5.7) with
the particle fluctuations kept, dt = t_c/50, N = 1000, H = 30).  Factors that
only change the imposition of (5.7) branch from the *same* base states as the
baseline (paired comparison); factors that change the base state run their own.

Resumable: every (base state, perturbation) is one cached .npz and every base
state one restart file in the cache directory; re-running skips what exists.
"""

from __future__ import annotations

import time
from dataclasses import replace

from . import ensemble as E
from .params import DEMParams

BASE = E.BaseState()
PERT = E.Perturbation()

#: factor -> (base state, perturbation); the first is the reference
FACTORS = {
    "baseline": (BASE, PERT),
    "drop_fluctuations": (BASE, replace(PERT, fluctuations="drop")),
    "local_temperature": (BASE, replace(PERT, fluctuations="local")),
    "dt_half": (BASE, replace(PERT, dt_fraction=BASE.params.dt_fraction / 2)),
    "rescale_preparation": (replace(BASE, preparation="rescale"), PERT),
    "long_shear": (replace(BASE, t_shear=90.0), PERT),
    "wide_cell": (replace(BASE, params=DEMParams(n_particles=2000)), PERT),
}

#: factors run together with the baseline on each of its base states
WITH_BASELINE = ("baseline", "drop_fluctuations", "local_temperature")


def run_factor(name, repeats, cache_dir, base_seed=1, progress=True, first=0):
    """Run (or load) ``repeats`` members of factor ``name``; list of results."""
    if name not in FACTORS:
        raise ValueError(f"`factor` must be one of {sorted(FACTORS)}; got {name!r}")
    base, pert = FACTORS[name]
    # the baseline also runs the cheap imposition factors on its base states
    siblings = [FACTORS[f][1] for f in WITH_BASELINE]
    out = []
    for i, seed in enumerate(E.seeds(first + repeats, base_seed, base.phi0)[first:]):
        t0 = time.perf_counter()
        rs = E.run_ensemble_member(base, seed, siblings if name == "baseline" else [pert], cache_dir)
        r = rs[siblings.index(pert)] if name == "baseline" else rs[0]
        out.append(r)
        if progress:
            print(f"{name}: member {first + i + 1}/{first + repeats} seed {seed} "
                  f"({time.perf_counter() - t0:.1f} s wall)", flush=True)
    return out


def main(argv=None):
    import argparse

    from .cache import default_cache_dir

    ap = argparse.ArgumentParser(prog="python -m icidr_pde.dem.audit",
                                 description="run the protocol-audit ensembles (resumable)")
    ap.add_argument("factors", nargs="+", choices=sorted(FACTORS))
    ap.add_argument("--repeats", type=int, default=10)
    ap.add_argument("--first", type=int, default=0, help="index of the first member (0)")
    ap.add_argument("--cache", default=None, help="cache directory (default: the user cache)")
    a = ap.parse_args(argv)
    for f in a.factors:
        run_factor(f, a.repeats, a.cache or default_cache_dir(), first=a.first)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())


def load_factor(name, cache_dir, repeats=None, base_seed=1):
    """Cached members of factor ``name`` (no LAMMPS): the first ``repeats`` seeds
    that are present, in seed order (all present ones when ``repeats`` is None)."""
    from . import cache

    base, pert = FACTORS[name]
    out = []
    for seed in E.seeds(repeats or 200, base_seed, base.phi0):
        r = cache.load(cache_dir, f"{base.key(seed)}_{pert.key()}")
        if r is None:
            if repeats is None:
                break
            continue
        out.append(r)
    return out
