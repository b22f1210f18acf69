"""A batch feeds the population step: population.json from
the ok single-test runs only, its section of the batch page, reuse when nothing changed, the
opt-out, the note with fewer than three usable tests, and a failure that leaves the batch ok."""

from __future__ import annotations

import csv
import json
from pathlib import Path

from support.batch import FEW, tiny_campaign

from bayes_dnlr.cli import main
from bayes_dnlr.workflows.batch.pooling import PopulationStep, select
from bayes_dnlr.workflows.batch.population_step import section


def _batch(template: Path, manifest: Path, out: Path, *extra: str) -> int:
    """One job at a time in this process: the population step reads the rows, whoever made them
    (worker processes are tests/workflows/batch/test_run.py's concern, and cost seconds each)."""
    return main(["batch", str(template), "--manifest", str(manifest), "--out", str(out), "--quiet",
                 "--jobs", "1", "--no-report", *extra])


def _set_column(manifest: Path, key: str, cells: dict[str, str]) -> None:
    """Add the manifest column ``key`` with ``cells`` (test name -> cell; empty for the others)."""
    with open(manifest, newline="") as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        r[key] = cells.get(r["name"], "")
    with open(manifest, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def _corrupt(path: Path) -> bytes:
    good = path.read_bytes()
    path.write_text("t_s,eps,stress_MPa\n0,0,0\n1,0.005,abc\n")
    return good


def test_batch_population_uses_the_ok_tests_only_and_is_reused(tmp_path, capsys):
    template, manifest = tiny_campaign(tmp_path, 5, sampler=FEW)
    _set_column(manifest, "parameters.E", {"t4": "{value: 2854}"})      # E fixed: not a specimen
    good = _corrupt(tmp_path / "data" / "t3.csv")
    out = tmp_path / "out"
    assert _batch(template, manifest, out) == 1                          # t3 failed
    printed = capsys.readouterr().out
    assert "population (done): 3 tests pooled" in printed and "left out: t3, t4" in printed

    data = json.loads((out / "population.json").read_text())
    assert data["specimens"] == ["t0", "t1", "t2"]                       # the ok tests with E sampled
    assert data["runs"] == {f"t{i}": f"runs/t{i}" for i in range(3)}
    assert data["made_by"] == "batch" and data["parameter"] == "E"
    assert set(data["monte_carlo_check"]) >= {"effective_draws", "passed"}
    assert data["mu"]["hdi_90"][0] < data["mu"]["mean"] < data["mu"]["hdi_90"][1]
    md = (out / "population.md").read_text()
    assert "Population of 3 specimens" in md and "Monte Carlo check" in md
    assert (out / "population.png").stat().st_size > 10_000

    page = (out / "batch.html").read_text()
    assert "Population of the tests (two-stage)" in page
    assert "E of the material: μ =" in page and "specimen-to-specimen sd" in page
    assert "Monte Carlo check <b>passed</b>" in page or "Monte Carlo check <b>FAILED</b>" in page
    assert "shrunken E (MPa)" in page and page.count("<tr><th>t") >= 3 + 5   # its table + All tests
    assert "<b>t3</b>: failed (" in page and "<b>t4</b>: E is fixed in its config" in page
    assert page.count("data:image/png;base64,") == 2                     # batch_E and population

    # the same batch again: nothing changed, the population is not redone
    stamp = {n: (out / n).stat().st_mtime_ns for n in ("population.json", "population.png")}
    assert _batch(template, manifest, out) == 1
    assert "population (reused): 3 tests" in capsys.readouterr().out
    assert {n: (out / n).stat().st_mtime_ns for n in stamp} == stamp
    assert "made earlier from these very runs and posteriors" in (out / "batch.html").read_text()

    # made by another version of the package: redone
    old = json.loads((out / "population.json").read_text())
    (out / "population.json").write_text(json.dumps({**old, "version": "0.0.1"}))
    assert _batch(template, manifest, out) == 1
    assert "population (done)" in capsys.readouterr().out
    assert "made by bayes_dnlr 0.0.1" in (out / "batch.html").read_text()
    assert json.loads((out / "population.json").read_text())["version"] != "0.0.1"

    # t3 fixed: four specimens now, the batch replaces its own earlier population.json
    (tmp_path / "data" / "t3.csv").write_bytes(good)
    assert _batch(template, manifest, out) == 0
    data = json.loads((out / "population.json").read_text())
    assert data["specimens"] == ["t0", "t1", "t2", "t3"]
    page = (out / "batch.html").read_text()
    assert "replaces the batch&#x27;s earlier population.json, made from 3 tests: t0, t1, t2)" in page


def test_fewer_than_three_tests_opt_out_and_failures_are_notes(tmp_path, capsys, monkeypatch):
    template, manifest = tiny_campaign(tmp_path, 3, sampler=FEW)
    goods = {i: _corrupt(tmp_path / "data" / f"t{i}.csv") for i in (1, 2)}
    out = tmp_path / "out"
    assert _batch(template, manifest, out) == 1
    assert "population (skipped)" in capsys.readouterr().out
    page = (out / "batch.html").read_text()
    assert "Population skipped" in page and "1 usable test (ok, one specimen each, E sampled)" in page
    assert "needs at least 3" in page and "<b>t1</b>: failed (" in page
    assert not (out / "population.json").exists()

    for i, good in goods.items():
        (tmp_path / "data" / f"t{i}.csv").write_bytes(good)
    assert _batch(template, manifest, out, "--no-population") == 0       # opt-out: none made
    assert "population (off)" in capsys.readouterr().out
    assert "Population not run</b>: turned off with --no-population" in (out / "batch.html").read_text()
    assert not any((out / f"population.{x}").exists() for x in ("json", "md", "png"))

    # a population.json that the population command wrote there from other runs is not replaced
    foreign = {"parameter": "E", "specimens": ["a", "b"], "runs": {"a": "x", "b": "y"},
               "fingerprints": {"a": "1", "b": "2"}, "made_by": "population"}
    (out / "population.json").write_text(json.dumps(foreign))
    assert _batch(template, manifest, out) == 0                          # the batch itself is ok
    assert json.loads((out / "population.json").read_text()) == foreign
    page = (out / "batch.html").read_text()
    assert "Population failed" in page and "made by the population command from other runs" in page
    (out / "population.json").unlink()

    # an error inside the population step: a note, the batch still succeeds
    def broken(*args, **kwargs):
        raise RuntimeError("grid exploded")

    monkeypatch.setattr("bayes_dnlr.workflows.batch.population_step.population_report", broken)
    assert _batch(template, manifest, out) == 0
    assert "population (failed): RuntimeError: grid exploded" in capsys.readouterr().out
    assert "grid exploded" in (out / "batch.html").read_text()
    monkeypatch.undo()
    assert _batch(template, manifest, out) == 0
    assert json.loads((out / "population.json").read_text())["specimens"] == ["t0", "t1", "t2"]


def test_a_joint_run_and_unfinished_tests_are_left_out_by_name(tmp_path):
    from support.joint import make_joint

    joint = make_joint(tmp_path).parent
    rows = [{"name": "joint", "status": "ok", "run_dir": str(joint), "E_mean": 2854.0},
            {"name": "late", "status": "pending"},
            {"name": "bad", "status": "failed", "error": "DataError: x.csv row 3"}]
    used, excluded = select(rows)
    assert used == {}
    assert excluded == {"joint": "a run with tests: (one E shared by several tests, not one specimen)",
                        "late": "not run", "bad": "failed (DataError: x.csv row 3)"}


def test_an_unreadable_population_json_is_a_note_not_a_broken_page():
    step = PopulationStep("reused", "made earlier", {"a": "x"}, {"b": "failed (x)"},
                          data={"parameter": "E", "specimens": ["a"]})       # no mu, s, shrunk
    page = section(step, lambda *a: "")
    assert "Population failed" in page and "population.json could not be shown (KeyError" in page
    assert "<b>b</b>: failed (x)" in page


def test_materials_get_a_population_each_and_the_table_carries_each_verdict(tmp_path, capsys):
    """Two materials (E 1500 and 2854 MPa, 3 tests each) named by a manifest column: one population
    per material, the table's trust columns; the same tests without the column (their runs reused):
    the heterogeneity check fires and the page says the tests do not look like one material."""
    import pandas as pd
    from support.sampling import TRUTH

    template, manifest = tiny_campaign(tmp_path, 6, sampler=FEW,
                                       params={i: {**TRUTH, "E": 1500.0} for i in range(3)})
    _set_column(manifest, "material", {f"t{i}": "A" if i < 3 else "B" for i in range(6)})
    out = tmp_path / "out"
    assert _batch(template, manifest, out) == 0
    pq = pd.read_parquet(out / "results.parquet")
    assert list(pq["material"]) == ["A"] * 3 + ["B"] * 3 and list(pq["in:material"]) == list(pq["material"])
    assert {"trust_interval", "adequate", "verdict", "checks_fired", "Et_t_s", "Et_mean", "Et_sd",
            "Et_hdi_lo", "Et_hdi_hi", "Et_trust"} <= set(pq.columns)
    assert pq["verdict"].notna().all() and pq["trust_interval"].notna().all()
    # a short chain: its own checks withdraw trust, and say so
    assert all("not_converged" in f for f in pq.loc[~pq["trust_interval"], "checks_fired"])
    data = json.loads((out / "population.json").read_text())
    assert set(data["groups"]) == {"A", "B"} and data["heterogeneity"]["passed"] is False
    assert data["groups"]["A"]["specimens"] == ["t0", "t1", "t2"]
    page = (out / "batch.html").read_text()
    assert "<h2>E by material</h2>" in page and "E of the material A" in page
    assert "E of the material B" in page and "do not look like one material" not in page

    with open(manifest) as f:                      # the same tests, the column left out
        text = f.read().splitlines()
    cols = text[0].split(",")
    at = cols.index("material")
    manifest.write_text("\n".join(",".join(c for j, c in enumerate(line.split(",")) if j != at)
                                  for line in text) + "\n")
    capsys.readouterr()
    assert _batch(template, manifest, out) == 0
    assert "6 ok (6 already done, skipped)" in capsys.readouterr().out     # labels are no results
    data = json.loads((out / "population.json").read_text())
    assert "groups" not in data and data["heterogeneity"]["passed"] is False
    assert set(data["heterogeneity"]["stand_out"]) in ({"t0", "t1", "t2"}, {"t3", "t4", "t5"})
    page = (out / "batch.html").read_text()
    assert "<b>The tests do not look like one material</b>" in page
    assert "E of the material" not in page and "Pooled E of these 6 tests" in page
