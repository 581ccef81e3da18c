"""Accuracy presets: discretization, N, integrator and tolerances chosen from measurements.

The numbers behind each choice come from ``python benchmarks/work_precision.py``
(data/benchmarks/work_precision.json, docs/performance.md, Presets): iCIDR reference cases
(i) scene shear to t = 10 and (ii) scene sine to t = 20, errors against N = 3201 references.

* ``draft``: fd, N = 51, CVODE rtol 1e-3: 0.008 s (shear), 0.011 s (sine) of solve; max|w|
  error 4.1e-3 (shear), 3.3e-3 (sine), profile error 0.25 (shear), 5.4e-3 (sine);
* ``standard`` (default): fd, N = 201, CVODE rtol 1e-5: 0.024 s (shear), 0.060 s (sine);
  max|w| error 2.4e-4 (shear), 4.7e-4 (sine): the N = 201 grid's own error, the time
  error is below it;
* ``publication``: fd, N = 801, CVODE rtol 1e-8: 0.16 s (shear), 0.87 s (sine); max|w|
  error 2.4e-5 (shear), 7.1e-5 (sine).

The compiled kernels are built once per installation and law, for every N
(:mod:`icidr_pde.rheology.codegen`); their set-up (compilation the first time, loading from
the disk cache afterwards) is reported apart as ``compile_s``. Chebyshev is not the default: the evolved iCIDR solutions are not smooth
(phi keeps a sharp dip), so it converges only algebraically and loses to fd at equal cost.

An explicit discretization, N, method, rtol or atol overrides that knob only.
"""

from __future__ import annotations

__all__ = ["PRESETS", "resolve"]

PRESETS = {
    "draft": dict(discretization="fd", N={"fd": 51, "cheb": 33}, method="CVODE", rtol=1e-3, atol=1e-6),
    "standard": dict(discretization="fd", N={"fd": 201, "cheb": 65}, method="CVODE", rtol=1e-5, atol=1e-8),
    "publication": dict(discretization="fd", N={"fd": 801, "cheb": 129}, method="CVODE", rtol=1e-8, atol=1e-11),
}


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
        settings.setdefault(key, preset[key])
    return settings
