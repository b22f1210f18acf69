"""Optional: a real machine export read as it is (no header row, strain in percent).

The real curves live in ../shared/data/real (not part of the project, never copied into it);
without that folder these tests skip.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from bayes_dnlr.config import parse_config
from bayes_dnlr.data import load_test

REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"
RHDPE = REAL / "rHDPE_Resin19_specimen3_tensile_50mm_per_min.csv"

pytestmark = pytest.mark.skipif(not RHDPE.is_file(), reason="../shared/data/real is absent (not part "
                                                           "of the project)")


def rhdpe_config(tmp_path: Path, **data):
    raw = {"name": "rhdpe", "data": {
        "file": str(RHDPE), "header": False, "columns": {"time": 2, "force": 4, "strain": 6},
        "strain_unit": "percent", "strain_measure": "nominal", "area0": 37.2, **data},
        "noise": {"sigma0": "residuals"}, "fit": {"multistart": 2}}
    return parse_config(raw, source=tmp_path / "config.yaml")


def test_machine_export_is_read_as_it_is(tmp_path):
    test = load_test(rhdpe_config(tmp_path))
    assert test.time.size == 26373                      # every row, none dropped
    assert np.all(np.diff(test.time) > 0)
    # the source cropped the rows below 0.5 % nominal strain (see the data README)
    assert test.nominal_strain[0] == pytest.approx(0.005001, abs=1e-6)
    # percent -> fraction: the nominal strain grows at the crosshead rate, 0.835 mm/s on ~104 mm
    assert np.polyfit(test.time, test.nominal_strain, 1)[0] == pytest.approx(0.835 / 104, rel=0.05)


def test_real_curve_before_necking_fits_and_its_residuals_show_bias(tmp_path):
    from bayes_dnlr.pipeline.fit import fit

    result = fit(rhdpe_config(tmp_path, window={"strain_max": 0.07}), write=False)
    assert result.converged
    assert 500 < result.estimate["E"] < 20000
    # the toe is cropped (the specimen is not relaxed at the first sample): the model cannot follow
    # the data to within the noise, and the diagnostics must say so
    assert result.diagnostics["white"] is False
