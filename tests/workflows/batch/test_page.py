"""The batch page's figure of E across the tests: a histogram only where there are enough tests to
make one (three means made bars of height 1 and 0), the forest plot of each test up to FOREST_MAX,
and a caption that names what is drawn."""

from __future__ import annotations

import numpy as np
import pytest

from bayes_dnlr.workflows.batch import figure as page


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
    ok = page.with_e(_rows(n))
    assert len(ok) == n                               # the failed test and the one without E left out
    fig = page.e_plot(ok)
    assert [ax.get_title() for ax in fig.axes] == titles
    caption = page.e_caption(n)
    assert ("histogram" in caption.lower()) == (n >= page.HISTOGRAM_MIN)
    assert ("90 % HDI" in caption) == (n <= page.FOREST_MAX)
    assert caption[0].isupper() and caption.endswith(".")
    assert ("Left:" in caption) == (len(titles) == 2)


# ---------------------------------------------------------------- trust and materials on the page

def _row(run_dir, material: str | None) -> dict:
    """A batch row of a drawn run, its trust read the way the batch reads it."""
    import json

    from bayes_dnlr.runs.modulus_across import run_entries
    from bayes_dnlr.workflows.batch.run import trust_columns

    summary = json.loads((run_dir / "summary.json").read_text())
    e = summary["posterior"]["E"]
    return {"name": run_dir.name, "status": "ok", "material": material, "run_dir": str(run_dir),
            "E_mean": e["mean"], "E_sd": e["sd"], "E_hdi90_lo": e["hdi_90"][0],
            "E_hdi90_hi": e["hdi_90"][1], "n_warnings": 1,
            "warnings": "G = 0 (its lower bound) | one of its own", **trust_columns(summary),
            "modulus_at": run_entries(summary)}


def _batch_page(tmp_path, materials: bool):
    """Two materials, 3 tests each (a2 not trusted by its own checks, E(t) on the A tests), one
    failed test; the batch page with its population step."""
    from support.drawn_runs import drawn_run, modulus_entry

    from bayes_dnlr.workflows.batch.page import write_page
    from bayes_dnlr.workflows.batch.pooling import PopulationStep
    from bayes_dnlr.workflows.batch.run import BatchResult
    from bayes_dnlr.workflows.population.run import run_population

    root = tmp_path / "runs"
    root.mkdir()
    rows = []
    for mat, e0, n in (("A", 1500.0, 3), ("B", 2500.0, 3)):
        for i in range(n):
            name = f"{mat.lower()}{i}"
            d = drawn_run(root, name, e0 + 7 * i, 25.0, material=mat if materials else None,
                          trust=name != "a2", seed=len(rows),
                          modulus=[modulus_entry(10.0, 0.8 * e0, 20.0, name != "a2")] if mat == "A" else None)
            rows.append(_row(d, mat if materials else None))
    rows.append({"name": "bad", "status": "failed", "error": "DataError: bad.csv line 3"})
    pr = run_population([r["run_dir"] for r in rows if r["status"] == "ok"], write=False)
    step = PopulationStep("done", "6 tests pooled.", {}, {"bad": "failed"}, data=pr.to_dict())
    result = BatchResult(rows, tmp_path, "1 local process", 1.0)
    return write_page(result, step).read_text(), rows


def test_the_page_marks_every_test_and_counts_the_trusted(tmp_path):
    html, rows = _batch_page(tmp_path, materials=True)
    first = html.split("<div class='box ", 1)[1].split("</div>", 1)[0]
    assert first.startswith("warn'>") and "<b>5 of 6 trusted</b> (not: a2)" in first
    assert "E(t): 2 of 3 trusted" in first
    # every test green or amber in the table of all tests, with its own decision
    assert html.count("<tr class='warn'><th>a2</th>") == 2          # Verdicts and All tests
    assert "<td class='flag'>no ⚑</td>" in html and html.count("<td class='text'>yes</td>") >= 5
    assert "do not use E&#x27;s interval as it is." in html and "model_form" in html
    # one result per material; a number drawn from an untrusted test is never plain
    assert "<h2>E by material</h2>" in html and "<th>A</th>" in html and "<th>B</th>" in html
    assert "E of the material A: μ =" in html and "E of the material B: μ =" in html
    assert "E of the material:" not in html                  # no E of a material across both
    box_a = html.split("E of the material A: μ =")[0].rsplit("<div class='box ", 1)[1]
    box_b = html.split("E of the material B: μ =")[0].rsplit("<div class='box ", 1)[1]
    assert box_a.startswith("warn") and box_b.startswith("ok")
    assert "The groups&#x27; E differ beyond their uncertainty" in html
    # E(t) beside E, the untrusted one flagged; whether a material's tests agree on it
    assert "<th>E(t = 10.0 s) (MPa)</th>" in html
    assert "E(t) (MPa) at the time every test resolves: pooled (range)" in html
    assert "<td class='flag'>1200 ± 12 (1200–1200) at t = 10.0 s</td>" in html   # a2's E(t) not trusted
    assert "<td class='text'>agree (Q = 0.0 on 2 degrees of freedom, p = 1, I² = 0 %)</td>" in html
    # a warning every test shares is listed once
    assert "<b>6 of 6 tests</b>: G = 0 (its lower bound)" in html
    assert html.count("G = 0 (its lower bound)") == 1


def test_the_forest_plot_is_grouped_and_flags_the_untrusted(tmp_path):
    _, rows = _batch_page(tmp_path, materials=True)
    ok = page.with_e(rows)
    fig = page.e_plot(ok)
    ax = fig.axes[0]
    labels = [t.get_text() for t in ax.get_yticklabels()]
    ys = [t.get_position()[1] for t in ax.get_yticklabels()]
    top_down = [lab for _, lab in sorted(zip(ys, labels, strict=True), reverse=True)]
    assert top_down == ["a0", "a1", "a2 ⚑", "b0", "b1", "b2"]      # by material, then by E
    assert {t.get_text() for t in ax.texts} == {"A", "B"}                  # the groups labelled
    assert "grouped by material" in page.e_caption(6, grouped=True)
    # E(t) beside it in the same rows: the A tests' at 10 s, a2's amber; the B tests have none
    fig = page.e_plot(ok, page.modulus_of_rows(ok))
    assert [a.get_title() for a in fig.axes] == ["E of each of 6 tests", "E(t) of each test (t = 10.0 s)"]
    et = fig.axes[1]
    assert [len(c.get_segments()) for c in et.collections] == [2, 1]      # trusted a0, a1; amber a2
    caption = page.e_caption(6, grouped=True, with_et=True)
    assert "each test's E(t) at the time every test of its material" in caption


def test_without_the_material_column_the_page_says_not_one_material(tmp_path):
    html, _ = _batch_page(tmp_path, materials=False)
    first = html.split("<div class='box ", 1)[1].split("</div>", 1)[0]
    assert "<b>The tests do not look like one material</b> (standing out:" in first
    assert "<b>Not one material</b>: The tests&#x27; E differ beyond their own uncertainty" in html
    assert html.count("differ beyond their own uncertainty (Q =") == 1     # said once
    assert "(E(t) not compared: no E(t) in b0, b1, b2" in html           # why E decides here
    assert ("Pooled E of these 6 tests (not shown as a material&#x27;s: their E differ beyond their "
            "own uncertainty)") in html
    assert "E of the material" not in html


def test_the_e_t_column_says_the_time_its_values_are_at(tmp_path):
    """Each material's E(t) at the time all its tests resolve: 2 s for A, whose first time 0.5 s one
    test does not resolve (the column said "E(t = 0.500 s)" over values at 2 s); a batch whose
    materials compare at two times says the time in each cell."""
    from support.drawn_runs import modulus_entry

    from bayes_dnlr.workflows.batch.page import write_page
    from bayes_dnlr.workflows.batch.run import BatchResult

    def row(name, material, at):
        return {"name": name, "status": "ok", "material": material, "E_mean": 1500.0, "E_sd": 20.0,
                "E_hdi90_lo": 1467.0, "E_hdi90_hi": 1533.0, "Et_t_s": at[0]["t"],
                "Et_mean": at[0]["mean"], "Et_sd": at[0]["sd"], "modulus_at": at}

    early = [modulus_entry(0.5, 1300.0, 3.0, resolved=(0.2, 50)), modulus_entry(2.0, 1200.0, 3.0,
                                                                                 resolved=(0.2, 50))]
    late = [modulus_entry(0.5, 1310.0, 3.0, resolved=(1.0, 50)), modulus_entry(2.0, 1205.0, 3.0,
                                                                                resolved=(1.0, 50))]
    rows = [row("a0", "A", early), row("a1", "A", late)]
    html = write_page(BatchResult(rows, tmp_path, "1 local process", 1.0)).read_text()
    assert "<th>E(t = 2.00 s) (MPa)</th>" in html and "<th>E(t = 0.500 s) (MPa)</th>" not in html
    assert "<td>1200.0 ± 3.0</td>" in html and "<td>1205.0 ± 3.0</td>" in html
    rows.append(row("b0", "B", [modulus_entry(0.5, 900.0, 3.0)]))
    html = write_page(BatchResult(rows, tmp_path, "1 local process", 1.0)).read_text()
    assert "<th>E(t) (MPa), at t</th>" in html
    assert "<td>1200.0 ± 3.0 at 2.00 s</td>" in html and "<td>900.0 ± 3.0 at 0.500 s</td>" in html


def test_a_warning_that_differs_only_in_its_numbers_is_listed_once_with_their_range(tmp_path):
    """G held at 0 by the fit of every test whose window ends at yield: its words are the same, its
    sensitivity differs from test to test. One item, the number as its range; a test's own warning
    stays in the test's row."""
    from bayes_dnlr.inference.lsq.sensitivity import hold_words
    from bayes_dnlr.workflows.batch.page import write_page
    from bayes_dnlr.workflows.batch.run import BatchResult

    def held(s: float) -> str:
        return hold_words({"G": {"value": 0.0, "sensitivity": s, "reference": 50.0, "sd": 1.0}})

    warned = {"t0": [held(0.004), "lag-1 autocorrelation +0.95 (Durbin-Watson 0.01)"],
              "t1": [held(0.012), "lag-1 autocorrelation +0.91 (Durbin-Watson 0.03)"],
              "t2": [held(0.007), "Err(tau_max) = 23 % (white least squares)"]}
    rows = [{"name": n, "status": "ok", "E_mean": 2000.0 + i, "E_sd": 50.0, "E_hdi90_lo": 1900.0 + i,
             "E_hdi90_hi": 2100.0 + i, "n_warnings": len(ws),
             "warnings": " | ".join(ws)} for i, (n, ws) in enumerate(warned.items())]
    html = write_page(BatchResult(rows, tmp_path, "1 local process", 1.0)).read_text()
    listed = html.split("Shared by several tests")[1].split("</ul>")[0]
    assert listed.count("<li>") == 2
    assert "<b>3 of 3 tests</b>: G held at 0 (its normalised sensitivity" in listed
    assert "is 0.4–1.2 % of the largest" in listed and html.count("G held at 0") == 1
    assert "<b>2 of 3 tests</b>: lag-1 autocorrelation +0.91–+0.95 (Durbin-Watson 0.01–0.03)" in listed
    assert "Err(tau_max) = 23 %" in html.split("its other warnings")[1]      # t2's own, in its row
