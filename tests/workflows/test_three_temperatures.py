"""The three-temperature benchmark (benchmarks/three_temperatures.py runs 30 replicates): one truth
with an Arrhenius a_T, three ramps, the one at the reference temperature with a hold, in one run."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

from three_temperatures import (  # noqa: E402
    REFERENCE,
    TEMPERATURES,
    TIMES,
    config,
    replicate,
    true_modulus,
    truth_of,
)

from bayes_dnlr.config import load_config  # noqa: E402
from bayes_dnlr.model.modulus import relaxation_modulus  # noqa: E402
from bayes_dnlr.model.shift import temperature_shift  # noqa: E402


@pytest.mark.parametrize("stress", [False, True])
def test_a_replicate_is_one_run_of_three_temperatures_from_one_truth(tmp_path, stress):
    raw = config(3, stress, 400.0)
    (tmp_path / "config.yaml").write_text(yaml.safe_dump(raw))
    cfg = load_config(tmp_path / "config.yaml")
    views = cfg.test_configs()
    assert [v.data.temperature for v in views] == list(TEMPERATURES)
    holds = [v.name for v in views if v.data.relaxation_start is not None]
    assert holds == [f"T{REFERENCE:g}"]
    params = truth_of(3, stress)
    assert all(v.truth.params["Ea"] == params["Ea"] for v in views)
    assert ("sigma_s" in cfg.parameter_names) is stress and "Ea" in cfg.parameter_names
    assert cfg.output.modulus_at == TIMES
    assert truth_of(3, stress) == params and truth_of(4, stress) != params


def test_the_true_modulus_at_a_temperature_is_the_reference_one_at_the_reduced_time():
    params = truth_of(0, False)
    a = float(temperature_shift(10.0, "arrhenius", REFERENCE, Ea=params["Ea"]))
    assert a > 1
    for t in (0.1, 1.0, 10.0):
        at_ten = true_modulus(t, params, 10.0)
        assert at_ten == pytest.approx(true_modulus(t / a, params))
        # the generator's modulus is the package's (model/modulus.py, shift_factor = a_T)
        assert at_ten == pytest.approx(relaxation_modulus([t], params["E"], params["G"],
                                                          params["tau_max"], shift_factor=a)[0])


@pytest.mark.slow
def test_ea_e_and_the_master_curve_are_covered(tmp_path):
    """Six replicates through fit and sample: for a calibrated 90 % interval, fewer than 4 of 6
    covering has probability 0.016."""
    records = [replicate((str(tmp_path), r, False, 400.0)) for r in range(6)]
    assert not [r["error"] for r in records if "error" in r]
    for k in ("Ea", "E"):
        covered = [r["posterior"][k]["interval"][0] <= r["truth"][k] <= r["posterior"][k]["interval"][1]
                   for r in records]
        assert sum(covered) >= 4, k
    rows = [m for r in records for m in r["reference"]]
    assert len(rows) == 6 * len(TIMES)
    assert np.mean([m["covered"] for m in rows]) >= 0.75
