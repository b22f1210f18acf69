"""The discrepancy analysis' warning when its whitened residuals are still not white."""

from __future__ import annotations

import numpy as np

from bayes_dnlr.inference.discrepancy import gls
from bayes_dnlr.inference.lsq.whiteness import residual_diagnostics


def test_the_warning_names_the_statistic_that_failed() -> None:
    """Runs of equal sign much longer than noise's, with a lag-1 autocorrelation near 0 (a real
    curve's whitened residuals looked so): the warning gives the runs and Durbin-Watson it rests
    on, not only the lag-1 autocorrelation, which alone would read as white."""
    rng = np.random.default_rng(3)
    signs = np.repeat(rng.choice([-1.0, 1.0], 25), 20)            # 25 runs of 20 samples
    e = signs * np.abs(rng.normal(size=signs.size))
    e[::2] *= 0.05                                                 # small between the large ones
    diag = residual_diagnostics(e)
    assert not diag["white"] and abs(diag["lag1_autocorrelation"]) < 0.3
    (text,) = gls._whiteness_warning(diag, False, "exp")
    runs = diag["runs_test"]
    assert f"{runs['n_runs']} sign runs for {runs['expected']:.0f} expected" in text
    assert f"Durbin-Watson {diag['durbin_watson']:.2f}" in text and "exp kernel" in text
    assert gls._whiteness_warning(diag, True, "exp") == []           # no model error: no warning
    assert gls._whiteness_warning(residual_diagnostics(rng.normal(size=500)), False, "exp") == []
