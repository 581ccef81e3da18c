"""Accuracy presets: discretization, N, integrator and tolerances chosen from measurements.

The numbers behind each choice come from ``python benchmarks/work_precision.py``
(data/benchmarks/work_precision.json, docs/performance.md, Presets): iCIDR reference cases
(i) scene shear to t = 10 and (ii) scene sine to t = 20, errors against N = 3201 references.

* ``draft``: fd, N = 51, CVODE rtol 1e-3: max|w| error 4.1e-3 (shear), 3.3e-3 (sine),
  profile error 0.25 (shear), 5.4e-3 (sine);
* ``standard`` (default): fd, N = 201, CVODE rtol 1e-5: max|w| error 2.4e-4 (shear), 4.7e-4
  (sine): the N = 201 grid's own error, the time error is below it;
* ``publication``: fd, N = 801, CVODE rtol 1e-8: max|w| error 2.4e-5 (shear), 7.1e-5 (sine).

Each costs more solve time than the one before (the times, measured, in docs/performance.md, Presets).

The compiled kernels are built once per installation and law, for every N
(:mod:`icidr_pde.rheology.codegen`); their set-up (compilation the first time, loading from
the disk cache afterwards) is reported apart as ``compile_s``. Chebyshev is not the default: the evolved iCIDR solutions are not smooth
(phi keeps a sharp dip), so it converges only algebraically and loses to fd at equal cost.

N, rtol and atol are per scheme. Chebyshev's tolerances are set by its headline number, the
failure time t* of mu(I), IC (3.16), N = 201 (converged 0.0105856, data/reference), which the
time error of CVODE moves at the level of rtol (docs/chebyshev.md): native CVODE, GMRES with
the band preconditioner (the native default), relative error of t* against that value
(``python benchmarks/cheb_krylov.py tstar --N 101 201 --solvers band --rtols 1e-5 1e-6 1e-7 1e-8 1e-9 1e-10``,
data/benchmarks/cheb_krylov_rtol.json; N = 101 against its own rtol 1e-10 run):

    rtol (atol = rtol / 1000)    1e-5     1e-6     1e-7     1e-8     1e-9
    N = 201                      3.7e-3   6.0e-4   7.4e-5   6.7e-6   1.4e-6
    N = 101                      7.9e-4   1.2e-4   1.9e-5   2.2e-6   2.5e-7

* ``draft``: cheb rtol 1e-3 (as fd);
* ``standard``: cheb rtol 1e-7, atol 1e-10: t* within 1e-3 with a margin of ten (rtol 1e-6
  gives 6.0e-4, too close to it), at a solve time of the same order as rtol 1e-5's;
* ``publication``: cheb rtol 1e-9, atol 1e-12: t* within 1e-5 (rtol 1e-8 gives 6.7e-6, too
  close to it).

An explicit discretization, N, method, rtol or atol overrides that knob only.
"""

from __future__ import annotations

__all__ = ["PRESETS", "resolve", "scheme_value"]

#: N, rtol and atol of a preset: a number, or one per scheme where they differ (a scheme not
#: named takes the fd value)
PRESETS = {
    "draft": dict(discretization="fd", N={"fd": 51, "cheb": 33}, method="CVODE", rtol=1e-3, atol=1e-6),
    "standard": dict(discretization="fd", N={"fd": 201, "cheb": 65}, method="CVODE",
                     rtol={"fd": 1e-5, "cheb": 1e-7}, atol={"fd": 1e-8, "cheb": 1e-10}),
    "publication": dict(discretization="fd", N={"fd": 801, "cheb": 129}, method="CVODE",
                        rtol={"fd": 1e-8, "cheb": 1e-9}, atol={"fd": 1e-11, "cheb": 1e-12}),
}


def scheme_value(value, discretization: str):
    """A preset's knob for `discretization`: `value` itself, or its entry (the fd one where the
    scheme has none) where it is given per scheme."""
    return value.get(discretization, value["fd"]) if isinstance(value, dict) else value


def resolve(accuracy: str = "standard", **overrides) -> dict:
    """Settings of preset `accuracy` with every non-None override applied.

    Returns a dict with keys discretization, N, method, rtol, atol.
    """
    if accuracy not in PRESETS:
        raise ValueError(f"`accuracy` must be one of {sorted(PRESETS)}; got {accuracy!r}")
    preset = PRESETS[accuracy]
    settings = {k: v for k, v in overrides.items() if v is not None}
    settings.setdefault("discretization", preset["discretization"])
    N = preset["N"].get(settings["discretization"])
    if N is None and "N" not in settings:  # only then the scheme's class (and py-pde) is needed
        from .discretizations import get_discretization

        N = get_discretization(settings["discretization"]).default_N
    settings.setdefault("N", N)
    for key in ("method", "rtol", "atol"):
        settings.setdefault(key, scheme_value(preset[key], settings["discretization"]))
    return settings
