"""The batch page's figure of E across the tests: a histogram only where there are enough tests to
make one (three means made bars of height 1 and 0), the forest plot of each test up to FOREST_MAX,
and a caption that names what is drawn."""

from __future__ import annotations

import numpy as np
import pytest

from bayes_dnlr.workflows.batch import page


def _rows(n: int) -> list[dict]:
    rng = np.random.default_rng(n)
    means = rng.normal(1600.0, 60.0, n)
    rows = [{"name": f"t{i}", "status": "ok", "E_mean": m, "E_hdi90_lo": m - 400.0,
             "E_hdi90_hi": m + 400.0} for i, m in enumerate(means)]
    return rows + [{"name": "bad", "status": "failed"}, {"name": "fixed", "status": "ok"}]


@pytest.mark.parametrize(("n", "titles"), [
    (3, ["E of each of 3 tests"]),
    (page.HISTOGRAM_MIN, [f"E across {page.HISTOGRAM_MIN} tests", "each test"]),
    (page.FOREST_MAX + 1, [f"E across {page.FOREST_MAX + 1} tests"]),
])
def test_the_panels_follow_the_number_of_tests(n: int, titles: list[str]):
    ok = page._with_e(_rows(n))
    assert len(ok) == n                               # the failed test and the one without E left out
    fig = page.e_plot(ok)
    assert [ax.get_title() for ax in fig.axes] == titles
    caption = page.e_caption(n)
    assert ("histogram" in caption.lower()) == (n >= page.HISTOGRAM_MIN)
    assert ("90 % HDI" in caption) == (n <= page.FOREST_MAX)
    assert caption[0].isupper() and caption.endswith(".")
    assert ("Left:" in caption) == (len(titles) == 2)
