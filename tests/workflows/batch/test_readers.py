"""The batch and population commands read a run folder's JSON files through the package's guarded
reader (bayes_dnlr/readback.py): a damaged summary.json or fit.json is named, never a traceback, and
a damaged file that only decides whether to reuse a result makes it computed again."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from support.finished_run import make_finished_run

from bayes_dnlr.config import load_config
from bayes_dnlr.errors import DamagedFileError
from bayes_dnlr.workflows.batch.manifest import jobs_from_configs
from bayes_dnlr.workflows.batch.run import current_row, result_row
from bayes_dnlr.workflows.population.run import current_population, read_existing


def _cut(path: Path) -> None:
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])


@pytest.mark.parametrize("name", ["summary.json", "fit.json"])
def test_a_damaged_result_file_is_named_in_the_batch_row(tmp_path, name) -> None:
    run = make_finished_run(tmp_path)
    job = jobs_from_configs([run / "config.yaml"])[0]
    cfg = load_config(run / "config.yaml")
    assert result_row(job, cfg)["E_mean"] is not None            # the intact run reads
    _cut(run / name)
    with pytest.raises(DamagedFileError, match=rf"{name}: damaged, not the JSON {name}"):
        result_row(job, cfg)


def test_a_damaged_row_or_summary_means_the_test_is_run_again(tmp_path) -> None:
    run = make_finished_run(tmp_path)
    job = jobs_from_configs([run / "config.yaml"])[0]
    out = tmp_path / "out"
    (out / "rows").mkdir(parents=True)
    row = {"status": "ok", "name": job.name, **result_row(job, load_config(run / "config.yaml"))}
    (out / "rows" / f"{job.name}.json").write_text(json.dumps(row))
    assert current_row(job, out, want_report=False)["reused"] is True
    (out / "rows" / f"{job.name}.json").write_bytes(b"\xff\xfe not json")
    assert current_row(job, out, want_report=False) is None
    (out / "rows" / f"{job.name}.json").write_text(json.dumps(row))
    _cut(run / "summary.json")
    assert current_row(job, out, want_report=False) is None


def test_population_reads_its_own_files_guarded(tmp_path) -> None:
    a = make_finished_run(tmp_path / "a")
    b = Path(shutil.copytree(a, tmp_path / "b" / "tiny"))
    (tmp_path / "population.json").write_bytes(b"[1, 2")                # cut
    assert read_existing(tmp_path / "population.json") == {}
    (tmp_path / "population.json").write_text("[1, 2]")                # not an object
    assert read_existing(tmp_path / "population.json") == {}
    (tmp_path / "population.json").write_text(json.dumps({"made_by": "population"}))
    assert current_population([a, b], out=tmp_path) is None           # other runs: not current
    _cut(b / "summary.json")
    assert current_population([a, b], out=tmp_path) is None            # and no traceback
