"""Regression tests of issue 41 ("What a researcher meets"): what a new user of the toolkit
runs into, each reproduced through the public API or the command line (``icidr_pde.cli.main``
in process)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest

from icidr_pde import run
from icidr_pde import cli


@pytest.fixture(scope="module")
def mui_failed():
    """mu(I) on scene shear at N = 101 fails at t* ~ 0.06, before its first default snapshot after 0."""
    res = run("mui", "shear", N=101, t_end=1)
    assert res.blew_up and list(res.times) == [0.0]
    return res


def _lines(fig):
    return [line for ax in fig.axes for line in ax.get_lines()]


def test_failed_run_keeps_the_last_states_before_t_star(mui_failed):
    res = mui_failed
    t = res.last_times
    assert 3 <= t.size <= 6 and np.all(np.diff(t) > 0) and 0.5 * res.t_star < t[0] and t[-1] < res.t_star
    assert res.last_states.shape == (t.size, 3, res.N)
    # the states are the run's own: max|w| there is the series' value at that time
    in_series = [(k, state) for time, state in zip(t, res.last_states)
                 for k in np.flatnonzero(res.max_w_t == time)]
    assert len(in_series) >= 3
    for k, state in in_series:
        assert np.max(np.abs(state[2])) == pytest.approx(res.max_w[k], rel=1e-12)


def test_plot_of_a_failed_run_draws_the_state_at_t_star_and_before(mui_failed):
    from icidr_pde.plotting import plot_result

    res = mui_failed
    fig = plot_result(res)
    drawn = [np.asarray(line.get_ydata()) for line in _lines(fig) if len(line.get_ydata()) == res.N]
    assert any(np.array_equal(y, res.final[2]) for y in drawn), "w at t* not drawn"
    assert any(np.array_equal(y, res.final[0]) for y in drawn), "phi at t* not drawn"
    before = [k for k, state in enumerate(res.last_states) if any(np.array_equal(y, state[2]) for y in drawn)]
    assert len(before) >= 3, "the last states before t* are not drawn"


def test_plot_of_a_failed_2d_run_draws_the_failure():
    from icidr_pde.plotting import plot_result

    res = run("mui", "bump2d", N=(32, 32), t_end=2)
    assert res.blew_up and res.last_times.size and res.last_states.shape[1:] == (3, 32, 32)
    fig = plot_result(res)
    images = [np.asarray(im.get_array()) for ax in fig.axes for im in ax.get_images()]
    assert any(np.array_equal(a, np.asarray(res.final[2]).T) for a in images), "w at t* not drawn"
    assert any(np.array_equal(a, np.asarray(res.last_states[-1][2]).T) for a in images)
    titles = " ".join(ax.get_title() for ax in fig.axes)
    assert f"t = {res.t_star:.4g}" in titles
