"""The pages as a reader meets them: the report and a batch page opened in headless Chromium at
1280 px (docs/screenshot.py drives it over the DevTools pipe).

On each page no table or figure is wider than the window, every image loads, the console shows no
error, and the first screen (800 px) holds what the page is for: the report's E with its interval
and the verdict; the batch page's count of trusted tests. The screenshot is the page's full height.
Skipped where no Chromium is installed, said on pytest's last line.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from support.browser import browser, png_size, screenshot
from support.finished_run import make_finished_run

from bayes_dnlr.numbers import interval, pm
from bayes_dnlr.runs.results import verdict_lines

WIDTH = 1280


def _reads_well(page) -> None:
    assert page.wide == [], page.wide                       # tables, figures, images inside the window
    assert page.scroll_width <= page.width == WIDTH          # nothing to scroll sideways
    assert page.images >= 1 and page.broken == []
    assert page.errors == []


def _headline(run: Path) -> tuple[str, str, str]:
    """E, its 90 % HDI and the verdict's first sentence, as the package writes them, from summary.json."""
    summary = json.loads((run / "summary.json").read_text())
    e = summary["posterior"]["E"]
    head, points = verdict_lines(summary["checks"])
    if not points:
        head = head.split(". ")[0] + "."
    return f"E = {pm(e['mean'], e['sd'])} MPa", f"90 % HDI {interval(*e['hdi_90'], e['sd'])}", head


def _check_report(run: Path, png: Path) -> None:
    page = screenshot.open_page(run / "report.html", WIDTH, png)
    _reads_well(page)
    for said in _headline(run):
        assert said in page.first_screen, (said, page.first_screen[:600])
    assert png_size(png) == (WIDTH, page.height)             # the whole page, not the first 9000 px
    return page


@browser
def test_the_report_reads_in_a_browser(tmp_path):
    run = make_finished_run(tmp_path, figures=True, page=True)
    page = _check_report(run, tmp_path / "report.png")
    assert page.images >= 5                                  # the fit, residuals, corner, ... figures


def _wide_batch(folder: Path) -> Path:
    """A batch page as wide as a campaign makes one: six ramp-then-hold tests with every parameter
    (E, G, tau_max, sigma_inf, tau_max_R, alpha), a material, E(t), long export names, three not
    trusted; its figure drawn."""
    from support.drawn_runs import drawn_run, modulus_entry

    from bayes_dnlr.workflows.batch.page import write_page
    from bayes_dnlr.workflows.batch.run import BatchResult, trust_columns

    values = {"E": (1180.0, 25.3), "G": (9.971, 1.7), "tau_max": (22.30, 7.1), "sigma_inf": (7.93, 0.21),
              "tau_max_R": (312.4, 45.6), "alpha": (0.512, 0.031)}
    rows = []
    for i in range(6):
        name = f"OUTRaw_MD_Rel_9MPa_T20-{i + 1}"
        trusted = i % 2 == 0
        d = drawn_run(folder / "runs", name, 1180.0 + 10 * i, 25.0, material="ETFE MD 20 °C",
                      trust=trusted, seed=i, modulus=[modulus_entry(2.0, 900.0, 20.0, trusted)])
        row = {"name": name, "status": "ok", "material": "ETFE MD 20 °C", "run_dir": str(d),
               "report": str(d / "report.html"), "n_warnings": 3, "warnings": "w1 | w2",
               "r_hat_max": 1.004, "ess_min": 1123.0, "iso527_1": 1002.4, "Et_mean": 912.3, "Et_sd": 13.2,
               "Et_trust": trusted, "Et_t_s": 2.0,
               **trust_columns(json.loads((d / "summary.json").read_text()))}
        for p, (m, sd) in values.items():
            m += 10 * i if p == "E" else 0.0
            row |= {f"{p}_mean": m, f"{p}_sd": sd, f"{p}_hdi90_lo": m - 1.645 * sd,
                    f"{p}_hdi90_hi": m + 1.645 * sd}
        rows.append(row)
    return write_page(BatchResult(rows, folder, "2 local processes (joblib, loky)", 31.0))


@browser
def test_a_wide_batch_page_fits_a_1280_px_window(tmp_path):
    html_file = _wide_batch(tmp_path)
    page = screenshot.open_page(html_file, WIDTH, tmp_path / "batch.png")
    _reads_well(page)
    assert "6 ok" in page.first_screen and "3 of 6 trusted" in page.first_screen
    assert png_size(tmp_path / "batch.png") == (WIDTH, page.height)


@pytest.mark.slow
@pytest.mark.real_data
@browser
def test_a_real_curves_report_reads_in_a_browser(tmp_path):
    """The report of a real curve (the ETFE export's first specimen, as `init` configures it): 10 000
    px tall, every section filled."""
    from support.real_data import ETFE, PRESENT, REASON

    if not PRESENT:
        pytest.skip(REASON)
    from bayes_dnlr.cli import main
    from bayes_dnlr.workflows.init import init_config

    config = init_config(ETFE, tmp_path / "etfe" / "config.yaml").path
    assert main(["sample", str(config), "--quiet", "--report"]) == 0
    page = _check_report(config.parent, tmp_path / "etfe.png")
    assert page.height > 9000
