"""corner is loaded without ArviZ and scipy.ndimage, and smooths its histograms as scipy would."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter as scipy_gaussian_filter

from bayes_dnlr.report.corner_loader import gaussian_filter


@pytest.mark.parametrize(("shape", "sigma"), [((30, 30), 1.0), ((30, 30), 2.5), ((5, 40), 1.0),
                                              ((3, 3), 1.0), ((100,), 1.5), ((12, 7), (0.7, 2.0))])
def test_the_smoothing_is_scipys(shape, sigma):
    values = np.random.default_rng(0).poisson(5.0, size=shape).astype(float)
    np.testing.assert_allclose(gaussian_filter(values, sigma), scipy_gaussian_filter(values, sigma),
                               rtol=1e-13, atol=1e-13)


def test_corner_loads_without_arviz_and_scipy_ndimage():
    code = ("import sys\n"
            "from bayes_dnlr.report.corner_loader import corner_impl, gaussian_filter\n"
            "corner_impl()\n"
            "import corner.core\n"
            "print(sorted(m for m in ('arviz', 'scipy.ndimage') if m in sys.modules),\n"
            "      corner.core.gaussian_filter is gaussian_filter,\n"
            "      'corner.arviz_corner' in sys.modules, 'scipy.ndimage' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["[]", "True", "False", "False"]


def test_a_scipy_already_loaded_is_corners_own():
    code = ("import scipy.ndimage\n"
            "from bayes_dnlr.report.corner_loader import corner_impl\n"
            "corner_impl()\n"
            "import corner.core\n"
            "print(corner.core.gaussian_filter is scipy.ndimage.gaussian_filter)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "True"
