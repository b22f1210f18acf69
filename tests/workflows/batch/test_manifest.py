"""Batch inputs: configs and globs, template + manifest (dotted keys), names, errors, where outputs go.
No sampling here: these are fast."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from support.sampling import write_case

from bayes_dnlr.cli import main
from bayes_dnlr.workflows.batch.manifest import (
    BatchError,
    default_out,
    expand_inputs,
    jobs_from_configs,
    jobs_from_manifest,
    parse_cell,
    set_dotted,
)


def _template(tmp_path: Path) -> Path:
    cfg = write_case(tmp_path / "cases", "base", n=50)
    raw = yaml.safe_load(cfg.read_text())
    raw["data"]["file"] = str(cfg.parent / "data.csv")
    raw["data"]["window"] = {"strain_max": 1.5}
    path = tmp_path / "template.yaml"
    path.write_text(yaml.safe_dump(raw))
    return path


def _manifest(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "lab" / "manifest.csv"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def test_parse_cell():
    assert parse_cell("3") == 3 and isinstance(parse_cell("3"), int)
    assert parse_cell("1e-3") == pytest.approx(1e-3)          # YAML 1.1 would read a string
    assert parse_cell(" 24.5 ") == 24.5
    assert parse_cell("null") is None
    assert parse_cell("true") is True
    assert parse_cell("{prior: half-normal, scale: 5}") == {"prior": "half-normal", "scale": 5}
    assert parse_cell("data/spec 1.csv") == "data/spec 1.csv"
    assert parse_cell("none") == "none"                       # discrepancy: none stays a word


def test_set_dotted_creates_and_refuses_to_descend_into_a_value():
    raw = {"data": {"window": {"strain_max": 1.9}}, "noise": {"sigma0": 0.3}}
    set_dotted(raw, "data.window.strain_min", 0.01)
    set_dotted(raw, "sampler.seed", 4)
    assert raw["data"]["window"] == {"strain_max": 1.9, "strain_min": 0.01}
    assert raw["sampler"] == {"seed": 4}
    with pytest.raises(ValueError, match="noise.sigma0 is 0.3 in the template, not a mapping"):
        set_dotted(raw, "noise.sigma0.prior", "half-normal")


def test_manifest_rows_override_the_template(tmp_path):
    template = _template(tmp_path)
    data = tmp_path / "lab" / "spec-2.csv"
    data.parent.mkdir(parents=True)
    data.write_bytes((tmp_path / "cases" / "base" / "data.csv").read_bytes())
    man = _manifest(tmp_path, "name,data.file,data.window.strain_max,sampler.seed\n"
                              "a,,0.13,7\n"
                              ",spec-2.csv,,\n")
    out = tmp_path / "out"
    jobs = jobs_from_manifest(template, man, out)
    assert [j.name for j in jobs] == ["a", "spec-2"]          # no name: the data file's stem
    a, b = (j.config() for j in jobs)
    assert a.data.window.strain_max == 0.13 and a.sampler.seed == 7
    assert b.data.window.strain_max == 1.5 and b.sampler.seed == 1     # empty cell: the template's
    assert a.data_path == tmp_path / "cases" / "base" / "data.csv"     # the template's file
    assert b.data_path == data                                 # relative to the manifest's folder
    assert a.run_dir == out.resolve() / "runs" / "a"
    assert jobs[0].inputs == {"name": "a", "data.window.strain_max": "0.13", "sampler.seed": "7"}
    assert jobs[0].origin.endswith("manifest.csv line 2")


def test_a_bad_row_becomes_a_failed_job_naming_row_and_key(tmp_path):
    template = _template(tmp_path)
    man = _manifest(tmp_path, "name,data.aera0,sampler.walkers\nok,,\nbad,24,\nworse,,-3\n")
    jobs = jobs_from_manifest(template, man, tmp_path / "out")
    assert jobs[0].error is None
    assert "manifest.csv line 3" in jobs[1].error and "data.aera0: unknown key" in jobs[1].error
    assert "line 4" in jobs[2].error and "sampler.walkers" in jobs[2].error


@pytest.mark.parametrize(("text", "message"), [
    ("", "the manifest is empty"),
    ("name,data.file\n", "has a header but no test rows"),
    ("name,data file\na,x.csv\n", "not a dotted config key"),
    ("name,name\na,b\n", "appear twice"),
    ("name\na\na\n", "same name"),
    ("name\na,b,c\n", "3 cells for 1 columns"),
])
def test_unusable_manifest_stops_the_batch(tmp_path, text, message):
    template = _template(tmp_path)
    with pytest.raises(BatchError, match=message):
        jobs_from_manifest(template, _manifest(tmp_path, text), tmp_path / "out")


def test_configs_globs_and_default_out(tmp_path):
    for i in range(3):
        write_case(tmp_path / "runs", f"r{i}", n=50)
    with pytest.raises(BatchError, match="listed twice"):      # a duplicate is said, not dropped
        expand_inputs([str(tmp_path / "runs" / "*" / "config.yaml"),
                       str(tmp_path / "runs" / "r0" / "config.yaml")])
    paths = expand_inputs([str(tmp_path / "runs" / "*" / "config.yaml")])
    assert [p.parent.name for p in paths] == ["r0", "r1", "r2"]
    assert default_out(paths, None) == (tmp_path / "runs" / "batch").resolve()
    assert default_out([], tmp_path / "lab" / "may.csv") == (tmp_path / "lab" / "batch-may").resolve()
    jobs = jobs_from_configs(paths)
    assert [j.run_dir for j in jobs] == [str((tmp_path / "runs" / f"r{i}").resolve()) for i in range(3)]
    with pytest.raises(BatchError, match="no such config file"):
        expand_inputs([str(tmp_path / "nothing" / "*.yaml")])


def test_same_name_in_two_configs_is_refused(tmp_path):
    a = write_case(tmp_path / "x", "same", n=50)
    b = write_case(tmp_path / "y", "same", n=50)
    with pytest.raises(BatchError, match="same name"):
        jobs_from_configs([a, b])


def test_cli_input_errors_are_one_line_exit_2(tmp_path, capsys):
    template = _template(tmp_path)
    assert main(["batch", str(template), str(template), "--manifest", str(tmp_path / "m.csv")]) == 2
    assert "takes one template config (or none, with a config column), got 2" in capsys.readouterr().err
    assert main(["batch", str(tmp_path / "none*.yaml")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1 and "Traceback" not in err
    assert main(["batch", str(template), "--manifest", str(tmp_path / "missing.csv")]) == 2
    assert "manifest not found" in capsys.readouterr().err


def test_results_table_takes_nested_and_mixed_values(tmp_path):
    """A run with tests: has per-test values (dicts); a failed row has text where others have numbers."""
    import pandas as pd

    from bayes_dnlr.workflows.batch.run import write_table

    rows = [{"name": "joint", "status": "ok", "sigma0_used": {"ta": 0.3, "tb": 0.3}, "E_mean": 2850.0,
             "converged": True, "inputs": {"data.file": "a.csv"}},
            {"name": "single", "status": "ok", "sigma0_used": 0.3, "E_mean": None, "converged": False},
            {"name": "bad", "status": "failed", "error": "DataError: x.csv: line 3", "E_mean": "n/a"}]
    csv_path, pq_path = write_table(rows, tmp_path)
    pq = pd.read_parquet(pq_path)
    assert list(pq["sigma0_used"])[:2] == ['{"ta": 0.3, "tb": 0.3}', "0.3"]
    assert pd.isna(pq.loc[2, "sigma0_used"])
    assert pq.loc[0, "E_mean"] == "2850.0" and pd.isna(pq.loc[1, "E_mean"]) and pq.loc[2, "E_mean"] == "n/a"
    assert list(pq["converged"])[:2] == [True, False]
    assert pq.loc[0, "in:data.file"] == "a.csv"
    assert list(pd.read_csv(csv_path)["name"]) == ["joint", "single", "bad"]


def test_scheduler_from_an_empty_dask_config_is_a_clear_error(tmp_path, capsys, monkeypatch):
    dask = pytest.importorskip("dask")
    pytest.importorskip("distributed")
    monkeypatch.delenv("DASK_SCHEDULER_ADDRESS", raising=False)
    cfg = write_case(tmp_path / "runs", "r0", n=50)
    with dask.config.set({"scheduler-address": None}):
        assert main(["batch", str(cfg), "--scheduler", "config", "--quiet"]) == 2
    assert "the Dask config has no scheduler-address" in capsys.readouterr().err
    assert not (tmp_path / "runs" / "batch").exists()


def test_a_material_column_names_each_tests_material(tmp_path):
    """The manifest column ``material`` is the config key ``material:``: a label, a resin number
    read as a label, or the template's when empty; a value that is no label fails that row."""
    template = _template(tmp_path)
    raw = yaml.safe_load(template.read_text())
    template.write_text(yaml.safe_dump({**raw, "material": "HDPE-A"}))
    man = _manifest(tmp_path, "name,material\na,PA6 (dry)\nb,19\nc,\nd,1.5\n")
    jobs = jobs_from_manifest(template, man, tmp_path / "out")
    assert [j.config().material for j in jobs[:3]] == ["PA6 (dry)", "19", "HDPE-A"]
    assert "line 5" in jobs[3].error and "material: expected a short label, got 1.5" in jobs[3].error
