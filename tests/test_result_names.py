"""max|w| in its two forms: Result.max_w_series (the time series at max_w_t) and the JSON's max_w
(values at the requested times); the series' old name, Result.max_w, reads it with a warning."""

import dataclasses
import json
import warnings

import numpy as np
import pytest

from icidr_pde import run


@pytest.fixture(scope="module")
def result():
    # iCIDR, IC (3.16), N = 21 to t = 1 (native engine): a series and three snapshot times
    return run("icidr", "shear", N=21, t_end=1.0, times=["0", "0.5", "1"])


def test_the_series_is_max_abs_w_of_the_states_at_its_times(result):
    assert len(result.max_w_series) == len(result.max_w_t) > 3
    # where the series meets a snapshot (its first and last time), max|w| recomputed from w
    assert result.max_w_t[0] == result.times[0] == 0 and result.max_w_t[-1] == result.times[-1] == 1
    assert result.max_w_series[0] == pytest.approx(np.max(np.abs(result.w[0])), rel=1e-12)
    assert result.max_w_series[-1] == pytest.approx(np.max(np.abs(result.final.w)), rel=1e-12)


def test_the_json_max_w_is_the_values_at_the_requested_times(result, tmp_path):
    result.save_json(tmp_path / "r.json")
    saved = json.loads((tmp_path / "r.json").read_text())
    assert set(saved["max_w"]) == {"0", "0.5", "1"} and "max_w_series" not in saved
    for label, w in zip(result.time_labels, result.w):
        assert saved["max_w"][label] == pytest.approx(float(np.max(np.abs(w))), rel=1e-15)
    assert saved["max_w"] == result.max_w_at_times()


def test_the_old_name_reads_and_sets_the_series_with_a_warning(result):
    with pytest.warns(DeprecationWarning, match=r"max_w_series .*JSON's 'max_w' is max\|w\| at the requested"):
        old = result.max_w
    assert old is result.max_w_series
    copy = dataclasses.replace(result)
    with pytest.warns(DeprecationWarning):
        copy.max_w = np.zeros(2)
    assert np.array_equal(copy.max_w_series, np.zeros(2))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result.max_w_series, result.max_w_t, result.to_dict()  # the new names warn about nothing
