"""Failure time t*(N) of a shear-cell run: the study of fig 4(b).

For the ill-posed mu(I),Phi(I)-rheology the discrete system blows up once the grid
resolves the short waves that grow fastest; the stiff integrator then cannot meet its
tolerances (step-size underflow, the paper's 'non-convergent') and the run stops at
t*. :func:`failure_time` runs one case with :func:`icidr_pde.api.run` on a Python engine
(the path the paper's t* are pinned on; ``engine="native"``: the compiled C problem and CVODE,
for Chebyshev GMRES with the low-order band preconditioner) without the max|w| series; :func:`sweep` computes t* for a range of N (in parallel, with a progress bar),
with the settings of :data:`ACCURACY` (``tstar``'s default: 'stated') where not given.

t* is a property of the discrete system and of the integrator (its tolerances, its
error control, even the round-off of the linear algebra), not of the PDE: the PDE is
ill-posed and has no failure time. See docs/chebyshev.md for the measurements.
"""

from __future__ import annotations

import json
import warnings

import numpy as np

from ..api import run
from ..discretizations.grid_size import CHEB, FD
from ..times import check_t_end
from ..validation import integer
from .parallel import StudyInterrupted, max_processes, run_cases

__all__ = ["failure_time", "failure_record", "sweep", "sweep_settings", "parse_range", "tstar_mapping", "tstar_report",
           "read_tstar_curves", "threshold", "SETTINGS", "TSTAR_SCHEMA", "PAPER_TSTAR", "BDF_RTOL", "BDF_ATOL",
           "ACCURACY"]

#: the paper's failure time of mu(I),Phi(I), IC (3.16), Chebyshev N_z = 201 (fig 4)
PAPER_TSTAR = {"N": 201, "t_star": 0.01052}
#: tolerances of scipy's BDF on which the committed t* of fig 4(b) are pinned (the paper's ode15s)
BDF_RTOL, BDF_ATOL = 1e-6, 1e-9
#: the settings of a sweep's runs by accuracy and discretization. 'paper': the paper's (scipy's BDF,
#: rtol 1e-6, atol 1e-9: the regression anchors and the committed data/tstar/mui_shear_*_BDF_*.json).
#: 'stated': the least costly settings whose t* meets the accuracy stated for it over fig 4(b)'s N
#: (21..201 step 2), as ``python benchmarks/tstar_accuracy.py`` measured them (data/tstar/tstar_accuracy.json,
#: docs/chebyshev.md): a Chebyshev t* within 1e-3 relative of the converged t* at every N (GMRES with the
#: band preconditioner, rtol 1e-7: 7.8e-5 at most; rtol 1e-6: 6.0e-4, too close to it; the dense LU costs
#: more at either); a finite-volume t* within the larger of 1e-2 and the scatter of rtol 1e-9, 1e-10, 1e-11
#: at every N >= 121 (band LU, rtol 1e-7; rtol 1e-6 and 1e-5 miss it at N = 125 and 129). Both fail from the
#: paper's thresholds on (Chebyshev N >= 57, finite volumes N >= 61) and decay below them.
ACCURACY = {
    "stated": {"fd": dict(engine="native", method="CVODE", rtol=1e-7, atol=1e-10),
               "cheb": dict(engine="native", method="CVODE", rtol=1e-7, atol=1e-10)},
    "paper": {"fd": dict(engine="pde", method="BDF", rtol=BDF_RTOL, atol=BDF_ATOL),
              "cheb": dict(engine="pde", method="BDF", rtol=BDF_RTOL, atol=BDF_ATOL)},
}
#: what a t* depends on besides N, as each run records it (a t* is quoted with them, docs/chebyshev.md)
SETTINGS = ("rheology", "scene", "engine", "method", "linear_solver", "jacobian", "rtol", "atol", "t_end", "material",
            "scene_params")
#: the name and version of the ``tstar --json`` form :func:`tstar_report` writes
TSTAR_SCHEMA = "icidr-pde tstar 2"
#: largest N of a sweep: that of the 1-D scheme allowing most (each case is then checked
#: against its own scheme's maximum and memory)
MAX_SWEEP_N = max(FD.max_N, CHEB.max_N)
#: most cases one ``N`` text may name (fig 4(b) has 91 a discretization): a sweep of more
#: would run for months, and its list alone could exhaust the memory
MAX_CASES = 10_000


def parse_range(text: str) -> list[int]:
    """'21:201:2' -> [21, 23, ..., 201] (start:stop:step, stop included); '47' -> [47];
    '21,47,201' -> [21, 47, 201]. Every N lies in [4, :data:`MAX_SWEEP_N`] and the parts hold
    at most :data:`MAX_CASES` values, both checked on the numbers of the text before any list is
    made (a range's length is counted, not expanded)."""
    parts: list[range] = []
    try:
        for part in str(text).split(","):
            part = part.strip()
            if ":" in part:
                fields = [int(x) for x in part.split(":")]
                if len(fields) == 2:
                    fields.append(1)
                if len(fields) != 3:
                    raise ValueError
                start, stop, step = fields
                if step < 1 or stop < start:
                    raise ValueError
                parts.append(range(start, stop + 1, step))
            else:
                value = int(part)
                parts.append(range(value, value + 1))
    except ValueError:
        raise ValueError(f"`N` must look like start:stop:step (stop included), a number or "
                         f"a comma-separated list; got {text!r}") from None
    if not parts or min(r[0] for r in parts) < 4 or max(r[-1] for r in parts) > MAX_SWEEP_N:
        raise ValueError(f"every `N` must be in [4, {MAX_SWEEP_N}]; got {text!r}")
    count = sum(len(r) for r in parts)  # len of a range is arithmetic: nothing is expanded yet
    if count > MAX_CASES:
        raise ValueError(f"`N` must name at most {MAX_CASES} cases; got {count} in {text!r}")
    return sorted({n for r in parts for n in r})


def failure_time(
    rheology: str = "mui",
    scene: str = "shear",
    discretization: str = "cheb",
    N: int = 201,
    t_end: float = 20.0,
    *,
    method: str = "BDF",
    rtol: float | None = BDF_RTOL,
    atol: float | None = BDF_ATOL,
    jacobian: str | None = None,
    backend: str = "numpy",
    max_wall: float | None = None,
    engine: str = "pde",
    return_state: bool = False,
    times=None,
    **scene_params,
) -> dict:
    """Run one case without the max|w| and chi recorders and return t* (None if it reached `t_end`).

    The same case builder, solver and failure detection as :func:`icidr_pde.api.run`.
    `backend` is that of the right-hand side: 'numpy' needs no compilation and is as fast
    as numba here (the cost is in the implicit solves). `max_wall` (seconds) abandons a
    run that takes longer (reason 'timeout ...'). `engine` as :func:`~icidr_pde.api.run`'s
    ('pde': scipy's or scikit-sundae's solver; 'native' needs method 'CVODE' and takes the
    numba backend's kernels in C); `rtol`, `atol` None: the accuracy preset's for the scheme.

    Returns a dict with N, t_star, reason, wall_s (solve, without set-up), n_steps, n_rhs,
    n_jac, n_lu, the settings the run used as its :class:`~icidr_pde.result.Result` holds them
    (:data:`SETTINGS`, and discretization) (and, with `return_state`, t_final, z and the final state (3, N) or the
    state at t*; with `times`, snapshot_times and snapshots (n, 3, N) at those reached).
    """
    t_end = check_t_end(t_end)
    snap = sorted({float(t) for t in times}) if times is not None else []
    if any(not 0 <= t <= t_end for t in snap):
        raise ValueError(f"`times` must lie in [0, t_end]; got {times}")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = run(rheology, scene, N, t_end, snap or [0.0], discretization=discretization, method=method,
                     rtol=rtol, atol=atol, jacobian=jacobian, backend="numba" if engine == "native" else backend,
                     max_wall=max_wall, series_times=(), engine=engine, **scene_params)
    from .case_cache import finished

    out = failure_record(finished(result))
    if return_state:
        out.update(t_final=result.t_final, z=result.z, state=np.array(result.final))
    if times is not None:
        out.update(z=result.z, snapshot_times=list(result.times),
                   snapshots=np.stack([result.phi, result.u, result.w], axis=1))
    return out


def failure_record(result) -> dict:
    """What :func:`failure_time` returns of a :class:`~icidr_pde.result.Result` (of :func:`~icidr_pde.api.run`,
    or of a task of :func:`~icidr_pde.studies.distributed.run_many`): N, t_star, reason, wall_s, the
    counts and the settings (:data:`SETTINGS`, and discretization)."""
    return {"N": result.N, "t_star": result.t_star, "reason": result.reason, "wall_s": result.wall_s,
            **{k: getattr(result, k) for k in ("rheology", "scene", "discretization", "t_end", "method", "rtol",
                                               "atol", "jacobian", "material", "scene_params")},
            "engine": result.settings.get("engine"), "linear_solver": result.settings.get("linear_solver"),
            **{k: _int(getattr(result, k)) for k in ("n_steps", "n_rhs", "n_jac", "n_lu")}}


def _int(value):
    return None if value is None else int(value)


def _run_case(kwargs: dict) -> dict:
    return failure_time(**kwargs)


#: what :func:`failure_time` returns, as far as :func:`sweep` and ``tstar`` read it
_RESULT_SHAPE = ("a failure_time dict (N an int, t_star a number or None)",
                 lambda r: isinstance(r, dict) and isinstance(r.get("N"), int)
                 and (r.get("t_star") is None or isinstance(r.get("t_star"), (int, float))))


def sweep_settings(accuracy: str, discretization: str, *, engine: str | None = None, method: str | None = None,
                   rtol: float | None = None, atol: float | None = None) -> dict:
    """engine, method, rtol and atol of a sweep's runs of `discretization` at `accuracy` (a key of
    :data:`ACCURACY`), each one given (not None) taking the place of the accuracy's. An engine other
    than the accuracy's takes the settings of the accuracy that runs on it ('pde': the paper's,
    'native': the stated ones); a method of scipy's (BDF, Radau, LSODA) runs on the 'pde' engine
    where no engine is given. A scheme :data:`ACCURACY` does not name takes the paper's method and
    tolerances on 'pde', and the run preset's tolerances (None) on 'native' and 'petsc'."""
    if accuracy not in ACCURACY:
        raise ValueError(f"`accuracy` must be one of {sorted(ACCURACY)}; got {accuracy!r}")
    if engine is None and method is not None and method != "CVODE":
        engine = "pde"
    rows = {name: table.get(discretization) for name, table in ACCURACY.items()}
    row = rows[accuracy]
    if row is None or (engine is not None and engine != row["engine"]):
        wanted = engine or ACCURACY[accuracy]["fd"]["engine"]
        cvode = wanted in ("native", "petsc")  # PETSc's runs ask for CVODE as the native engine's do
        row = next((r for r in (rows[accuracy], *rows.values()) if r is not None and r["engine"] == wanted),
                   dict(engine=wanted, method="CVODE" if cvode else "BDF",
                        rtol=None if cvode else BDF_RTOL, atol=None if cvode else BDF_ATOL))
    given = dict(engine=engine, method=method, rtol=rtol, atol=atol)
    return {key: row[key] if given[key] is None else given[key] for key in given}


def sweep(
    Ns,
    discretizations=("cheb",),
    *,
    jobs: int = 2,
    progress: bool = True,
    client=None,
    cache=None,
    accuracy: str | None = None,
    **kwargs,
) -> dict[str, dict[int, dict]]:
    """t* for every N and discretization: {discretization: {N: failure_time(...) dict}}.

    Runs in `jobs` worker processes (spawned, with one BLAS thread each; jobs=1 runs
    in this process), or as tasks of the dask `client` (:mod:`.distributed`), with a
    tqdm progress bar. `kwargs` go to :func:`failure_time`; with `accuracy` (a key of
    :data:`ACCURACY`) the engine, method and tolerances not given in them (or given as None) are
    those of :func:`sweep_settings` for each discretization. With `cache` (a folder,
    :class:`~.case_cache.CaseCache`) every finished case is kept there as it arrives and a
    case already there is not run again: an interrupted sweep resumes. Interrupted (Ctrl-C),
    :class:`~.parallel.StudyInterrupted` holds the mapping of the cases that finished.
    """
    from .case_cache import run_cached

    Ns = [int(n) for n in Ns]
    per_scheme = {d: {} for d in discretizations}
    if accuracy is not None:
        given = {key: kwargs.pop(key, None) for key in ("engine", "method", "rtol", "atol")}
        per_scheme = {d: sweep_settings(accuracy, d, **given) for d in discretizations}
    # the costliest runs first, so that no worker is left with a long one at the end: Chebyshev's
    # (dense operators) before the finite volumes' (banded), large N first within each
    cases = [dict(kwargs, **per_scheme[d], discretization=d, N=n)
             for d in sorted(discretizations, key=lambda d: d != "cheb") for n in sorted(Ns, reverse=True)]

    def label(case, res):
        t = "none" if res["t_star"] is None else f"{res['t_star']:.5g}"
        return f"{case['discretization']} N={res['N']} t*={t}"

    def by_scheme(results):
        out: dict[str, dict[int, dict]] = {d: {} for d in discretizations}
        for case, res in zip(cases, results):
            if res is not None:
                out[case["discretization"]][case["N"]] = res
        return {d: dict(sorted(v.items())) for d, v in out.items()}

    if client is None:  # checked as run_cases checks it, then no worker started that would have no case
        jobs = min(integer("jobs", jobs, 1, max_processes()), max(1, len(cases)))
    try:
        return by_scheme(run_cached(_run_case, cases, cache, "failure_time", jobs=jobs, progress=progress,
                                    postfix=label, desc="t*(N)", client=client,
                                    expect=_RESULT_SHAPE))
    except StudyInterrupted as interrupt:
        raise StudyInterrupted(by_scheme(interrupt.done)) from interrupt


def tstar_mapping(results: dict[int, dict]) -> dict[str, float | None]:
    """{'N': t*} with N as strings (the JSON form)."""
    return {str(n): r["t_star"] for n, r in sorted(results.items())}


def _by_scheme(runs) -> dict[str, dict[int, dict]]:
    """{discretization: {N: record}} of a list of :class:`~icidr_pde.result.Result` (what
    :func:`~icidr_pde.studies.distributed.run_many` returns); a case whose task raised is refused
    (ValueError naming it): it has no t* and no reason of the run."""
    out: dict[str, dict[int, dict]] = {}
    for i, run_ in enumerate(runs):
        if not hasattr(run_, "t_star") or not hasattr(run_, "settings"):
            raise ValueError(f"`results[{i}]` must be a Result of a run; got {str(run_)[:200]}")
        record = failure_record(run_)
        out.setdefault(record["discretization"], {})[record["N"]] = record
    return out


def tstar_report(results) -> dict:
    """The ``tstar --json`` document of a :func:`sweep`'s results ({discretization: {N: record}})
    or of a list of :class:`~icidr_pde.result.Result` (:func:`~icidr_pde.studies.distributed.run_many`'s,
    on this machine or a cluster: the same document), one form for any number of discretizations::

        {"schema": TSTAR_SCHEMA,
         "discretizations": {"fd": {"settings": {"rheology": ..., "rtol": ..., ...},
                                    "settings_by_N": {},
                                    "t_star": {"21": null, ...},
                                    "reason": {"21": null, ...}}}}

    `settings` holds each of :data:`SETTINGS` on which the runs of a discretization agree, read
    from the runs themselves; a setting on which they differ (a linear solver chosen per N, say)
    is in `settings_by_N` instead, as {setting: {N: value}}. `reason` is why the run of each N
    failed, null where it reached t_end.
    """
    if not isinstance(results, dict):
        results = _by_scheme(results)
    out = {}
    for disc, runs in results.items():
        runs = {n: failure_record(r) if hasattr(r, "settings") else r for n, r in sorted(runs.items())}
        settings, by_n = {}, {}
        for key in SETTINGS:
            values = {str(n): r.get(key) for n, r in runs.items()}
            if len({json.dumps(v, sort_keys=True) for v in values.values()}) <= 1:
                settings[key] = next(iter(values.values()), None)
            else:
                by_n[key] = values
        out[disc] = {"settings": settings, "settings_by_N": by_n, "t_star": tstar_mapping(runs),
                     "reason": {str(n): None if r["t_star"] is None else r.get("reason") for n, r in runs.items()}}
    return {"schema": TSTAR_SCHEMA, "discretizations": out}


def read_tstar_curves(document) -> dict[str, dict]:
    """{discretization: {'N': t*}} of a ``tstar --json`` document: the form of :func:`tstar_report`,
    or the earlier ones (a flat {'N': t*}, under the key '' here, or one such mapping per
    discretization). Anything else is a ValueError."""
    if isinstance(document, dict) and "schema" in document:
        if document["schema"] != TSTAR_SCHEMA or not isinstance(document.get("discretizations"), dict):
            raise ValueError(f"schema must be {TSTAR_SCHEMA!r} with a 'discretizations' object; got "
                             f"{document['schema']!r}")
        curves = {}
        for disc, entry in document["discretizations"].items():
            if not isinstance(entry, dict) or not isinstance(entry.get("t_star"), dict):
                raise ValueError(f"discretization {disc!r} must hold a 't_star' object {{N: t*}}")
            curves[disc] = entry["t_star"]
        return curves
    if isinstance(document, dict) and document and all(isinstance(v, dict) for v in document.values()):
        return dict(document)
    if isinstance(document, dict):
        return {"": document}
    raise ValueError(f"must hold a JSON object; got a {type(document).__name__}")


def threshold(mapping: dict) -> int | None:
    """Smallest N such that every N >= it in `mapping` failed (None if the largest did not)."""
    items = sorted((int(n), t) for n, t in mapping.items())
    thr = None
    for n, t in reversed(items):
        if t is None:
            break
        thr = n
    return thr


