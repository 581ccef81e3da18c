"""Every registered engine meets the Engine contract (an abstract base class): its methods
implemented, its constructor the contract's, its state declared; the native engine integrates a
Problem as the others do. Independent truth for the native engine's advance(): scipy's BDF on the
same ODE (the compiled problem's rates through Problem.fun)."""

from __future__ import annotations

import inspect

import numpy as np
import pytest

from icidr_pde.engines import ENGINES, engine_class
from icidr_pde.engines.base import Engine

#: the constructor's positional parameters, then its keywords (an engine may take more keywords)
POSITIONAL = ["self", "method", "problem", "t0"]
KEYWORDS = {"rtol", "atol", "max_step", "first_step", "linear_solver", "max_order"}


def _classes():
    for name in ENGINES:
        try:
            yield name, engine_class(name)
        except ImportError:  # an optional engine whose library is not installed (PETSc)
            continue


def test_the_contract_is_abstract():
    assert inspect.isabstract(Engine)
    assert {"__init__", "advance", "value_at", "counts"} <= Engine.__abstractmethods__
    with pytest.raises(TypeError):
        Engine("CVODE", None, 0.0, rtol=1e-6, atol=1e-8)


@pytest.mark.parametrize("name", list(ENGINES))
def test_every_registered_engine_implements_the_contract(name):
    classes = dict(_classes())
    if name not in classes:
        pytest.skip(f"engine {name!r} is not installed here")
    cls = classes[name]
    assert issubclass(cls, Engine) and not inspect.isabstract(cls), cls.__abstractmethods__
    assert cls.name == name and cls.methods == ENGINES[name].methods
    parameters = inspect.signature(cls.__init__).parameters
    assert list(parameters)[:len(POSITIONAL)] == POSITIONAL, list(parameters)
    keywords = {k for k, p in parameters.items() if p.kind == p.KEYWORD_ONLY}
    assert KEYWORDS <= keywords, KEYWORDS - keywords
    required = {k for k, p in parameters.items() if p.kind == p.KEYWORD_ONLY and p.default is p.empty}
    assert required <= {"rtol", "atol"}, required
    for attribute in ("linear_solver", "ran", "ranks"):
        assert hasattr(cls, attribute)


def _native_problem():
    from icidr_pde.engines.native import native_problem
    from icidr_pde.native import NativeUnavailable
    from icidr_pde.native_case import FdCase

    case = FdCase("icidr", "sine", 21)
    try:
        compiled = case.problem()
    except NativeUnavailable as err:
        pytest.skip(f"native engine not available: {err}")
    return case, native_problem(compiled, case.y0, case.check_state)


def test_the_native_engine_integrates_a_problem_as_scipy_does():
    from icidr_pde.engines.base import JacobianSpec, Problem

    case, problem = _native_problem()
    native = engine_class("native")("CVODE", problem, 0.0, rtol=1e-10, atol=1e-12)
    reference = Problem(y0=problem.y0, fun=problem.fun, jacobian=JacobianSpec("none"), check=problem.check)
    scipy = engine_class("scipy")("BDF", reference, 0.0, rtol=1e-10, atol=1e-12)
    for engine in (native, scipy):  # the declared state
        assert engine.problem is not None and engine.t == 0.0
        assert isinstance(engine.linear_solver, str) and engine.ran is None and engine.ranks == 1
    for t in (0.5, 1.0):
        assert native.advance(t) is None and scipy.advance(t) is None
        a, b = native.value_at(t), scipy.value_at(t)
        assert np.max(np.abs(a - b)) <= 1e-6 * np.max(np.abs(b))
    assert native.t == 1.0 and np.max(np.abs(case.fields(a)[2])) > 1e-3  # the sine did evolve
    steps, jacobians, lus = native.counts()
    assert steps > 0 and jacobians > 0
    with pytest.raises(ValueError, match="last output"):
        native.value_at(0.75)


def test_the_native_engine_needs_a_compiled_problem():
    from icidr_pde.engines.base import JacobianSpec, Problem

    python_only = Problem(y0=np.zeros(3), fun=lambda t, y: y, jacobian=JacobianSpec("analytic"),
                          check=lambda y: None)
    with pytest.raises(ValueError, match="compiled problem"):
        engine_class("native")("CVODE", python_only, 0.0, rtol=1e-6, atol=1e-8)


def test_the_recorders_meet_the_recorder_protocol(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    from icidr_pde.case import build_case
    from icidr_pde.live_plot import LivePlot
    from icidr_pde.movies.frames import MovieFrames
    from icidr_pde.recorders import Recorder, WallClock
    from icidr_pde.snapshots import SnapshotFile

    case = build_case("icidr", "shear", "fd", 9)
    recorders = [LivePlot(case.nodes(), 1.0), MovieFrames(tmp_path / "m.gif", case.nodes(), 1.0),
                 SnapshotFile(tmp_path / "s.h5", case.nodes(), [0.0, 1.0], case.state), WallClock(1.0, 1.0)]
    for recorder in recorders:
        assert isinstance(recorder, Recorder), type(recorder)
        recorder.abandon()
    assert not isinstance(object(), Recorder)
