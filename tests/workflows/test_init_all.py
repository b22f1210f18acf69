"""``init FILE --all``: a config per specimen of an export that holds several side by side and the
batch manifest that runs them all, with the material and temperature the file states; the batch
runs each specimen where its config runs alone."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from support.export_corpus import _ramp, _rows
from support.real_data import ETFE, REAL_MARKS

from bayes_dnlr.cli import main
from bayes_dnlr.config import load_config, parse_config
from bayes_dnlr.data import load_test
from bayes_dnlr.errors import RunError
from bayes_dnlr.runs.fit import fit
from bayes_dnlr.workflows import init_all as init_all_module
from bayes_dnlr.workflows.batch.manifest import jobs_from_manifest, read_manifest
from bayes_dnlr.workflows.init_all import init_all
from bayes_dnlr.workflows.init_labels import read_labels


def _three(tmp_path: Path) -> tuple[Path, list[float]]:
    """Three specimens side by side (time, strain in %, engineering and true stress each) past their
    load peak, under a metadata block that names the material and the test temperature; the time
    of each specimen's peak."""
    specs = [_ramp(300 + 40 * k, 0.4, seed, params={"E": e, "G": 2.32, "tau_max": 5.79})
             for k, (seed, e) in enumerate(((11, 2700.0), (12, 2850.0), (13, 3000.0)))]
    header, cols = [], []
    for k, d in enumerate(specs, 1):
        header += [f"Time {k} (s)", f"Strain {k} (%)", f"Stress {k} (MPa)", f"True stress {k} (MPa)"]
        cols += [d["t"], 100 * d["e"], d["eng"], d["true"]]
    n = min(c.size for c in cols)
    meta = ['"Sample","three bars"', '"Material","HDPE-A"', '"Test temperature","23","°C"', ""]
    path = tmp_path / "three-bars.csv"
    path.write_text("\n".join([*meta, ",".join(header), *_rows([c[:n] for c in cols])]) + "\n")
    peaks = [float(f"{d['t'][int(np.argmax(d['eng'][:n]))]:.10g}") for d in specs]
    return path, peaks


def test_all_writes_a_config_per_specimen_and_the_manifest_that_runs_them(tmp_path):
    path, peaks = _three(tmp_path)
    result = init_all(path, tmp_path / "runs" / "three")
    assert [r.path.parent.name for r in result.configs] == [f"three-bars-{k}" for k in (1, 2, 3)]
    for k, (r, peak) in enumerate(zip(result.configs, peaks, strict=True), 1):
        cfg = load_config(r.path)
        assert cfg.data.specimen == k and cfg.material == "HDPE-A" and cfg.data.temperature == 23.0
        assert all(e.key != "data.specimen" for e in r.edits)      # no "which one?": each is written
        assert "material: HDPE-A   # read from the file's line 2:" in r.path.read_text()
        test = load_test(cfg)
        assert test.time[test.window][-1] == peak                  # its own load peak, not the first's
    header, rows = read_manifest(result.manifest)
    assert header == ["name", "config", "material", "data.temperature"]
    assert [r["config"] for _, r in rows] == [f"three-bars-{k}/config.yaml" for k in (1, 2, 3)]
    assert {(r["material"], r["data.temperature"]) for _, r in rows} == {("HDPE-A", "23.0")}
    manifest_text = result.manifest.read_text()
    assert "# material and data.temperature: each row's config's" in manifest_text
    assert f"batch --manifest {result.manifest}" in manifest_text and result.text().endswith(
        "docs/batch.md (the manifest)")
    jobs = jobs_from_manifest(None, result.manifest, tmp_path / "out")
    assert [j.error for j in jobs] == [None] * 3
    for j, r in zip(jobs, result.configs, strict=True):
        assert Path(j.run_dir) == load_config(r.path).run_dir       # where the config runs alone
        assert j.config().data.specimen == int(j.name[-1]) and j.inputs["config"].endswith("config.yaml")


def test_the_batch_of_the_manifest_runs_each_specimen_in_its_own_folder(tmp_path, capsys):
    """A short chain per specimen (the manifest's cells override each row's own config, as they do
    a template)."""
    path, _ = _three(tmp_path)
    result = init_all(path, tmp_path / "three")
    rows = list(csv.reader(line for line in result.manifest.read_text().splitlines()
                           if not line.startswith("#")))
    rows = [rows[0] + ["sampler.walkers", "sampler.max_steps", "sampler.checkpoint_every"]] + \
           [r + ["8", "20", "10"] for r in rows[1:]]
    with open(result.manifest, "w", newline="") as f:
        csv.writer(f).writerows(rows)
    assert main(["batch", "--manifest", str(result.manifest), "--jobs", "1", "--no-report",
                 "--no-population", "--quiet"]) == 0
    table = pd.read_csv(tmp_path / "three" / "batch-specimens" / "results.csv")
    assert list(table["status"]) == ["ok"] * 3 and set(table["material"]) == {"HDPE-A"}
    for r in result.configs:
        assert (r.path.parent / "summary.json").is_file()           # beside its own config


def test_a_manifest_takes_a_template_or_a_config_column_not_both(tmp_path, capsys):
    path, _ = _three(tmp_path)
    result = init_all(path, tmp_path / "three")
    template = result.configs[0].path
    assert main(["batch", str(template), "--manifest", str(result.manifest)]) == 2
    assert "not both" in capsys.readouterr().err
    plain = tmp_path / "plain.csv"
    plain.write_text("name,data.specimen\na,1\n")
    assert main(["batch", "--manifest", str(plain)]) == 2
    assert "not neither" in capsys.readouterr().err
    missing = tmp_path / "missing.csv"
    missing.write_text("config\nnowhere/config.yaml\n")
    [job] = jobs_from_manifest(None, missing, tmp_path / "out")
    assert "missing.csv line 2" in job.error and "no such file" in job.error


def test_all_never_overwrites_and_leaves_nothing_of_a_failed_call(tmp_path, monkeypatch):
    path, _ = _three(tmp_path)
    folder = tmp_path / "runs" / "three"
    real = init_all_module.init_config
    calls = []

    def third_fails(*args, **kw):
        calls.append(kw.get("specimen"))
        if len(calls) == 3:
            raise RunError("disk full (simulated)")
        return real(*args, **kw)

    monkeypatch.setattr(init_all_module, "init_config", third_fails)
    with pytest.raises(RunError, match="simulated"):
        init_all(path, folder)
    assert not folder.exists() and not (tmp_path / "runs").exists()
    monkeypatch.setattr(init_all_module, "init_config", real)
    init_all(path, folder)
    before = {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()}
    with pytest.raises(RunError, match="exists; init never overwrites"):
        init_all(path, folder)
    assert {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()} == before


@pytest.mark.parametrize(("head", "material"), [
    ("Werkstoff;PP-H 23\nPrüftemperatur;296,15;K\n", "PP-H 23"), ("Material: HDPE\nRate;5\n", "HDPE"),
    ("Sample;bar 3\nRate;5\n", None)])
def test_the_material_a_metadata_block_states(tmp_path, head, material):
    path = tmp_path / "zwick.csv"
    path.write_text(head + "\nt;e;s\n"
                    + "\n".join(f"{i};{i / 100:.2f};{i}".replace(".", ",") for i in range(20)) + "\n")
    from bayes_dnlr.data.guess import read_columns

    label = read_labels(path, read_columns(path)[0]).material
    assert (label.value if label else None) == material
    assert label is None or "line 1" in label.where


@pytest.mark.parametrize("specimen", [1, 2, 3], ids=lambda k: f"specimen{k}")
@REAL_MARKS[0]
@REAL_MARKS[1]
def test_all_on_the_real_etfe_export_gives_each_specimens_hand_written_E(tmp_path, specimen):
    """The three ETFE specimens: each config fits to the E of the config docs/data-input.md writes by
    hand for that specimen (with the temperature init reads from the file's name), to 1e-9."""
    result = init_all(ETFE, tmp_path / "etfe")
    assert len(result.configs) == 3
    assert result.configs[specimen - 1].raw["data"]["temperature"] == 40.0      # the name's 'T40C'
    mine = fit(load_config(result.configs[specimen - 1].path), write=False)
    hand = parse_config({"name": "hand", "data": {"file": str(ETFE), "specimen": specimen,
                                                  "columns": {"time": 1, "eps11": 8, "stress": 10},
                                                  "observable": "stress", "temperature": 40.0},
                         "noise": {"sigma0": "residuals"}}, source=tmp_path / "hand" / "config.yaml")
    assert mine.estimate["E"] == pytest.approx(fit(hand, write=False).estimate["E"], rel=1e-9)
    assert yaml.safe_load(result.configs[specimen - 1].path.read_text())["data"]["specimen"] == specimen
