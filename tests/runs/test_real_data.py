"""Optional: real machine exports read as they are, with a config only.

The real curves live outside the project, never copied into it (tests/support/real_data.py finds them:
$BAYES_DNLR_REAL_DATA or ../shared/data/real); without them these tests skip, and the summary says
so. No file is edited and no origin row is made by hand: everything is in the config.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from support.real_data import ETFE, REAL_MARKS, RHDPE

from bayes_dnlr.config import parse_config
from bayes_dnlr.data import load_test

pytestmark = list(REAL_MARKS)


def rhdpe_config(tmp_path: Path, parameters: dict | None = None, **data):
    """rHDPE: no header, 7 columns [index, time s, extension mm, force N, stress MPa, strain %, strain %]."""
    raw = {"name": "rhdpe", "data": {
        "file": str(RHDPE), "columns": {"time": 2, "force": 4, "strain": 6},
        "strain_unit": "percent", "strain_measure": "nominal", "area0": 37.2, **data},
        "noise": {"sigma0": "residuals"}, "fit": {"multistart": 2}}
    if parameters:
        raw["parameters"] = parameters
    return parse_config(raw, source=tmp_path / "config.yaml")


def etfe_config(tmp_path: Path, specimen: int, **data):
    """ETFE: no header, 45 columns = 3 specimens x 15 (time, strains, stresses, ...), padded at the end."""
    raw = {"name": f"etfe-{specimen}", "data": {
        "file": str(ETFE), "specimen": specimen, "columns": {"time": 1, "eps11": 8, "stress": 10},
        "observable": "stress", **data},
        "noise": {"sigma0": "residuals"}, "fit": {"multistart": 4}}
    return parse_config(raw, source=tmp_path / "config.yaml")


def test_machine_export_is_read_as_it_is(tmp_path):
    test = load_test(rhdpe_config(tmp_path, reduce="none"))   # (auto averages pairs of rows: 26373 > 20000)
    assert test.time.size == 26373                      # every row, none dropped
    assert np.all(np.diff(test.time) > 0)
    assert test.notes[0].startswith("format: delimiter ',' (detected), decimal point (detected), no header")
    # the source cropped the rows below 0.5 % nominal strain (see the data README)
    assert test.nominal_strain[0] == pytest.approx(0.005001, abs=1e-6)
    # percent -> fraction: the nominal strain grows at the crosshead rate, 0.835 mm/s on ~104 mm
    assert np.polyfit(test.time, test.nominal_strain, 1)[0] == pytest.approx(0.835 / 104, rel=0.05)
    # the cropped toe is named: the first sample carries 249.3 N, 6.7 MPa on 37.2 mm²
    assert any(n.startswith("warning: the first sample (line 1) carries 249.3 N (6.7") for n in test.notes)


def test_windowed_strain_rate_is_the_windows(tmp_path):
    """The rate was 0.00287 1/s (the whole record) instead of about 0.0076 (the window)."""
    test = load_test(rhdpe_config(tmp_path, window={"strain_max": 0.07}))
    assert 0.0072 < test.strain_rate < 0.0080


@pytest.mark.parametrize(("start", "low", "high"), [({"initial_state": "ramp-from-zero"}, 2000, 2500),
                                                    ({"toe": "compensate"}, 1900, 2500)])
def test_cropped_toe_from_a_config_only(tmp_path, start, low, high):
    """The export starts at 0.5 % strain and 6.7 MPa. Taken as unloaded there, the
    fit gives E near 4800 MPa; with an unloaded start before it (a config key, no hand-made row) E is
    near the 2269 MPa of a hand-made origin row. G is fixed: a pre-yield window does not identify it
    (the paper's interval I identifies E and tau_max)."""
    from bayes_dnlr.runs.fit import fit

    params = {"G": {"value": 0.0}}
    result = fit(rhdpe_config(tmp_path, params, window={"strain_max": 0.07}, **start), write=False).only
    assert result.converged
    assert low < result.estimate["E"] < high, result.estimate
    assert result.diagnostics["rms"] < 0.3
    plain = fit(rhdpe_config(tmp_path, params, window={"strain_max": 0.07}), write=False).only
    assert plain.estimate["E"] > 3000 and plain.diagnostics["rms"] > 1.0


@pytest.mark.parametrize("specimen", [1, 2, 3])
def test_etfe_specimens_split_by_column_group_and_padding_dropped(tmp_path, specimen):
    test = load_test(etfe_config(tmp_path, specimen))
    notes = "\n".join(test.notes)
    assert f"specimen {specimen} of 3: columns {15 * specimen - 14}-{15 * specimen} (groups of 15" in notes
    assert 900 < test.time.size < 1020 and np.all(np.isfinite(test.stress))
    assert test.time[0] == 0 and test.strain[0] == 0 and test.stress[0] == 0
    if test.time.size < 1017:
        assert "padding: the last" in notes


def test_etfe_specimen_fits_from_a_config_only(tmp_path):
    from bayes_dnlr.runs.fit import fit

    r = fit(etfe_config(tmp_path, 1, strain_input="smoothed"), write=False).only
    assert r.converged
    assert 1500 < r.estimate["E"] < 3000                 # README: roughly 1.9-2.4 GPa
    assert 1.0 < r.diagnostics["rms"] < 2.5              # README: 1.3-2.0 MPa
    assert r.diagnostics["white"] is False
