"""Presets resolve as documented, and the cached references are consistent (no timings)."""


import numpy as np
import pytest

from icidr_pde import run
from icidr_pde.presets import PRESETS, resolve
from icidr_pde.studies.references import CASES, REFERENCE_DIR, reference, series_error


def test_presets_resolve_and_explicit_knobs_override():
    assert resolve()["N"] == PRESETS["standard"]["N"]["fd"]  # standard is the default
    assert resolve("draft")["rtol"] == PRESETS["draft"]["rtol"]
    s = resolve("publication", N=101, method="BDF")
    assert s["N"] == 101 and s["method"] == "BDF" and s["rtol"] == PRESETS["publication"]["rtol"]["fd"]
    cheb = resolve("standard", discretization="cheb")
    assert cheb["N"] == PRESETS["standard"]["N"]["cheb"]
    # tolerances per scheme: Chebyshev's t* needs a tighter rtol than fd's max|w| (presets docstring)
    assert (cheb["rtol"], cheb["atol"]) == (PRESETS["standard"]["rtol"]["cheb"], PRESETS["standard"]["atol"]["cheb"])
    assert cheb["rtol"] < resolve("standard")["rtol"]
    assert resolve("standard", discretization="cheb", rtol=1e-4)["rtol"] == 1e-4
    assert resolve("standard", discretization="fv2d")["rtol"] == PRESETS["standard"]["rtol"]["fd"]
    with pytest.raises(ValueError, match="accuracy"):
        resolve("best")


def test_run_records_the_settings_it_used():
    res = run("icidr", "shear", t_end=0.5, times=[0.5], accuracy="draft", rtol=1e-4)
    assert res.N == PRESETS["draft"]["N"]["fd"] and res.rtol == 1e-4
    assert res.method == PRESETS["draft"]["method"]
    assert res.to_dict()["settings"]["accuracy"] == "draft"


@pytest.mark.parametrize("case", sorted(CASES))
def test_reference_cache_is_consistent(case):
    """The committed reference matches the code's scene, material and settings, is
    converged in space and time as recorded, conserves mass and decays to (3.10)."""
    assert (REFERENCE_DIR / f"{case}.npz").exists(), "run: icidr-pde study references"
    ref = reference(case)
    meta = ref["meta"]
    spec = CASES[case]
    res = run(spec["rheology"], spec["scene"], 51, 0.1, [0.1], accuracy="draft")
    assert meta["scene_params"] == res.scene_params and meta["material"] == res.material
    assert meta["t_end"] == spec["t_end"] and list(ref["times"]) == spec["profile_times"]
    assert meta["space_check"]["series_error"] < 3e-4 and meta["time_check"]["series_error"] < 1e-4
    assert meta["time_check"]["profile_error"] < 1e-6
    assert abs(meta["mass_drift"]) < 1e-12
    max_w = np.abs(ref["w_series"]).max(axis=1)
    assert max_w[-1] < 0.02 * max_w[0]  # decays towards (3.10)
    initial_peak = {"shear": 0.05 * np.exp(-0.5) / np.sqrt(2), "sine": 0.1}[spec["scene"]]  # (3.16), (5.7)
    assert ref["series_t"][0] == 0.0 and max_w[0] == pytest.approx(initial_peak, rel=1e-3)


def test_series_error_of_the_reference_against_itself_is_zero():
    """The error measure compares maxima over the same nodes: zero for the reference."""
    ref = reference("icidr-sine")

    class Same:
        z = ref["z_series"]
        w = ref["w_series"]

    assert series_error(Same, ref) == 0.0
