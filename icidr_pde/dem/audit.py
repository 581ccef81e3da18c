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

from dataclasses import replace

from ..studies.parallel import run_cases
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


def _perturbations(name):
    """The perturbations run on the base states of factor `name`: the baseline also runs the
    cheap imposition factors on its base states."""
    return [FACTORS[f][1] for f in WITH_BASELINE] if name == "baseline" else [FACTORS[name][1]]


def run_factors(names, repeats, cache_dir, base_seed=1, *, first=0, jobs=1, client=None, progress=True):
    """Run (or load) members ``first .. first + repeats - 1`` of every factor in `names`:
    {name: list of results}.

    Each (base state, seed) is one task, running every perturbation the factors ask of it
    (:func:`~icidr_pde.dem.ensemble.run_ensemble`): `jobs` worker processes of this machine or
    tasks of the dask `client`, resuming from the cache in `cache_dir` (one every worker sees).
    """
    unknown = [n for n in names if n not in FACTORS]
    if unknown or not names:
        raise ValueError(f"`factors` must be among {sorted(FACTORS)}; got {list(names)}")
    members: dict = {}  # (base state, seed) -> perturbations, in the order first asked
    for name in names:
        base = FACTORS[name][0]
        for seed in E.seeds(first + repeats, base_seed, base.phi0)[first:]:
            perts = members.setdefault((base, seed), [])
            perts.extend(p for p in _perturbations(name) if p not in perts)
    cases = [dict(base=base, seed=int(seed), perts=perts, cache_dir=str(cache_dir))
             for (base, seed), perts in members.items()]
    done = {(c["base"], c["seed"]): dict(zip(c["perts"], results)) for c, results in
            zip(cases, run_cases(E.member_task, cases, jobs, progress, desc="audit members", client=client,
                                 init_here=False))}
    out = {}
    for name in names:
        base, pert = FACTORS[name]
        out[name] = [done[base, seed][pert] for seed in E.seeds(first + repeats, base_seed, base.phi0)[first:]]
    return out


def run_factor(name, repeats, cache_dir, base_seed=1, progress=True, first=0, *, jobs=1, client=None):
    """Run (or load) ``repeats`` members of factor ``name``; list of results (:func:`run_factors`)."""
    return run_factors([name], repeats, cache_dir, base_seed, first=first, jobs=jobs, client=client,
                       progress=progress)[name]


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
