"""The report's Table 4 (report/table4.py): the standards, E(t), E and each reference with the
model's prediction at its time scale; its figure; compare's Table 4 across runs."""

from __future__ import annotations

import html
import json
import re

import pytest

from bayes_dnlr.config import load_config
from bayes_dnlr.numbers import pm
from bayes_dnlr.report import build_report
from bayes_dnlr.report.compare import compare_runs
from bayes_dnlr.runs.fit import fit
from bayes_dnlr.runs.sample import sample
from tests.support.references import PULSE_ECHO, SWEEP, run_with_references

NANO = {"method": "nanoindentation", "value": 2790.0, "sd": 60.0, "frequency": 45.0}


@pytest.fixture(scope="module")
def sampled(tmp_path_factory):
    path = run_with_references(tmp_path_factory.mktemp("t4"), [PULSE_ECHO, NANO, SWEEP,
                                                               {"method": "manufacturer", "value": 1200}])
    sample(load_config(path), progress=False)
    return path.parent


def _rows(page: str) -> dict[str, str]:
    body = page[page.index("Table 4: the modulus"):]
    body = body[:body.index("</table>")]
    return {html.unescape(re.sub("<[^>]+>", "", m.group(1))): m.group(0)
            for m in re.finditer(r"<tr><th[^>]*>(.*?)</th>.*?</tr>", body)}


def test_table_4_sets_each_reference_beside_the_prediction_at_its_time_scale(sampled):
    page = build_report(sampled).read_text()
    rows = _rows(page)
    s = json.loads((sampled / "summary.json").read_text())
    e = s["posterior"]["E"]
    assert {"ISO 527-1", "ASTM D638", "E, model-based (posterior mean)", "pulse-echo",
            "nanoindentation", "manufacturer", "dma, sweep of 16 frequencies"} <= set(rows)
    assert any(k.startswith("E(t), the first time resolved") for k in rows)
    pe = rows["pulse-echo"]
    assert "every mode frozen: E" in html.unescape(pe) and pm(e["mean"], e["sd"]) in pe
    nano = next(r for r in s["reference_moduli"] if r["label"] == "nanoindentation")
    assert pm(nano["prediction"]["mean"], nano["prediction"]["sd"]) in rows["nanoindentation"]
    assert f"{100 * (2790 - e['mean']) / e['mean']:+.1f} %" in rows["nanoindentation"]   # vs E
    assert "none given" in rows["manufacturer"]
    assert "E with the data references" in page and "id=\"table4\"" in page
    assert (sampled / "figures" / "table4.png").stat().st_size > 10_000


def test_a_fit_only_run_shows_the_linearized_predictions(tmp_path):
    path = run_with_references(tmp_path, [PULSE_ECHO, NANO])
    fit(load_config(path))
    page = build_report(path.parent).read_text()
    rows = _rows(page)
    f = json.loads((path.parent / "fit.json").read_text())
    assert "least squares, linearized" in page
    assert pm(f["estimate"]["E"], f["sd"]["E"]) in rows["pulse-echo"]
    assert not (path.parent / "figures" / "table4.png").exists()     # the curve comes with a posterior


def test_compare_gives_table_4_across_the_runs(tmp_path):
    a = run_with_references(tmp_path, [PULSE_ECHO, NANO], name="a")
    b = run_with_references(tmp_path, [{**PULSE_ECHO, "value": 2300.0}], name="b")
    for p in (a, b):
        fit(load_config(p))
    comp = compare_runs([a.parent, b.parent])
    md = (tmp_path / "compare.md").read_text()
    assert "Table 4 across the runs" in md
    assert comp.table4.header[-2:] == ["pulse-echo", "nanoindentation"]
    row_b = next(r for r in comp.table4.rows if r[0] == "b")
    assert row_b[-1] == "–" and "⚑" in row_b[-2]                # b's pulse-echo is far off; no nano
    assert "ref_pulse-echo_z" in (tmp_path / "compare.csv").read_text().splitlines()[0]
