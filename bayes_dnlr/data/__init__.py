"""The data layer: reading test exports, the paper's conversions (eq. 1-8), the smoothed strain
input, windows and checks. ``load_test(cfg)`` gives the ``TestData`` the model is fitted to.

Modules, one concern each:

- ``errors``: ``DataError`` (names file, line and column).
- ``reading``: the CSV (sniffing and reading machine exports) to floats.
- ``conversions``: eq. 1-8 (Hencky/nominal strain, true/nominal stress).
- ``checks``: plausibility of the read columns.
- ``repeats``: rows that repeat a time stamp (``data.repeated_time``).
- ``ramp``: the ramp's strain rate and the start of a relaxation hold.
- ``cycles``: the turning points of a loading-unloading test.
- ``smoothing``: the GCV smoothing spline of the strain.
- ``windows``: identification windows.
- ``baseline``: the baseline noise of a window where the specimen is unloaded.
- ``testdata``: ``TestData`` and ``load_test``, the assembly.

Equation numbers refer to Blaise et al. (shared/paper); see docs/data-input.md.
"""

from bayes_dnlr.data.baseline import baseline_sd
from bayes_dnlr.data.conversions import (
    haward_thackray_strain,
    hencky_from_nominal,
    nominal_from_hencky,
    nominal_from_true_stress,
    nominal_stress,
    sigma_star,
    true_stress,
)
from bayes_dnlr.data.errors import DataError
from bayes_dnlr.data.ramp import detect_relaxation_start, ramp_strain_rate
from bayes_dnlr.data.reading import read_table
from bayes_dnlr.data.smoothing import gcv_lambda, segment_edges, smooth_segment, smooth_strain
from bayes_dnlr.data.testdata import TestData, load_test
from bayes_dnlr.data.windows import window_mask

__all__ = [
    "DataError", "TestData", "baseline_sd", "detect_relaxation_start", "gcv_lambda",
    "haward_thackray_strain", "hencky_from_nominal", "load_test", "nominal_from_hencky",
    "nominal_from_true_stress", "nominal_stress", "ramp_strain_rate", "read_table", "segment_edges",
    "sigma_star", "smooth_segment", "smooth_strain", "true_stress", "window_mask",
]
