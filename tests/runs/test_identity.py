"""A run's identity is what it computes from, not how its config spells the data path: a chain
continues under every spelling of the same file (relative, ``./``, absolute, from another
folder), the batch's rerun of one test works, a chain made with the previous form of the
fingerprint continues, and a real change is refused with the keys that changed and the CLI's ways
on (never the Python ``restart=True``).
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml
from support.batch import FEW, tiny_campaign
from support.sampling import write_case

from bayes_dnlr import cli
from bayes_dnlr.config import load_config
from bayes_dnlr.runs.chains import read_run
from bayes_dnlr.runs.folder import config_digest as legacy_config_digest
from bayes_dnlr.runs.folder import section_digests as legacy_section_digests

# never converges: each call samples to max_steps, and raising it continues the chain
SAMPLER = {"walkers": 8, "max_steps": 20, "target_ess": 1.0e9, "checkpoint_every": 10, "seed": 3}
PARAMETERS = {"E": {"prior": "uniform", "low": 100, "high": 20000}}


@pytest.fixture
def run(tmp_path: Path) -> Path:
    return write_case(tmp_path, "syn", n=200, sampler=SAMPLER, parameters=PARAMETERS)


def _edit(config: Path, **changes) -> None:
    raw = yaml.safe_load(config.read_text())
    for dotted, value in changes.items():
        node = raw
        *parents, last = dotted.split("__")
        for k in parents:
            node = node[k]
        node[last] = value
    config.write_text(yaml.safe_dump(raw, sort_keys=False))


def _sample(config: Path | str, capsys, *extra: str) -> tuple[int, str]:
    code = cli.main(["sample", "--quiet", str(config), *extra])
    out, err = capsys.readouterr()
    return code, out + err


def test_every_spelling_of_the_data_path_continues_the_chain(run: Path, capsys, monkeypatch) -> None:
    code, text = _sample(run, capsys)
    assert code == 0, text
    fit_mtime = (run.parent / "fit.json").stat().st_mtime_ns
    chains = run.parent / "chains.h5"
    first = read_run(chains)
    spellings = ["./data.csv", str(run.parent / "data.csv"), "../syn/data.csv", "data.csv"]
    for i, spelling in enumerate(spellings, start=2):
        _edit(run, data__file=spelling, sampler__max_steps=20 * i)
        code, text = _sample(run, capsys)
        assert code == 0, f"{spelling}: {text}"
        stored = read_run(chains)
        assert stored.steps == 20 * i, spelling
        np.testing.assert_array_equal(stored.chain[:20], first.chain)     # the same chain, continued
    assert (run.parent / "fit.json").stat().st_mtime_ns == fit_mtime      # the fit was kept too
    # from another folder, the absolute spelling of the config and the data
    monkeypatch.chdir(run.parent.parent.parent)
    _edit(run, data__file=str((run.parent / "data.csv").resolve()))
    code, text = _sample(run.resolve(), capsys)
    assert code == 0 and "finished earlier" in text, text


def test_continued_chain_equals_the_uninterrupted_one(tmp_path: Path, capsys) -> None:
    """Respelt between two sessions, the chain is bit for bit the one sampled in one go."""
    a = write_case(tmp_path / "a", "syn", n=200, sampler={**SAMPLER, "max_steps": 40},
                   parameters=PARAMETERS)
    b = write_case(tmp_path / "b", "syn", n=200, sampler=SAMPLER, parameters=PARAMETERS)
    assert _sample(a, capsys)[0] == 0
    assert _sample(b, capsys)[0] == 0
    _edit(b, data__file="./data.csv", sampler__max_steps=40)
    assert _sample(b, capsys)[0] == 0
    np.testing.assert_array_equal(read_run(a.parent / "chains.h5").chain,
                                  read_run(b.parent / "chains.h5").chain)


def test_the_rerun_of_one_batch_test(tmp_path: Path, capsys) -> None:
    """docs/batch.md: `sample <out>/runs/<name>/config.yaml` reruns one test of a manifest batch."""
    template, manifest = tiny_campaign(tmp_path, 2, points=150, sampler=FEW)
    out = tmp_path / "out"
    code = cli.main(["batch", str(template), "--manifest", str(manifest), "--out", str(out),
                     "--jobs", "1", "--no-report", "--no-population", "--quiet"])
    capsys.readouterr()
    assert code == 0
    config = out / "runs" / "t1" / "config.yaml"
    chains = config.parent / "chains.h5"
    before = chains.stat().st_mtime_ns
    code, text = _sample(config, capsys)
    assert code == 0 and "finished earlier" in text, text
    assert chains.stat().st_mtime_ns == before
    # and raising max_steps there continues that test's chain (100 steps past where it stopped)
    steps = read_run(chains).steps
    _edit(config, sampler__max_steps=steps + 100, sampler__target_ess=1e9)
    code, text = _sample(config, capsys)
    assert code == 0, text
    assert read_run(chains).steps > steps


def test_a_real_change_names_the_keys_and_keeps_the_chain(run: Path, capsys) -> None:
    assert _sample(run, capsys)[0] == 0
    chains = run.parent / "chains.h5"
    before = chains.read_bytes()
    _edit(run, parameters__E__high=30000)
    code, text = _sample(run, capsys)
    assert code == 2
    line = text.strip().splitlines()[-1]
    assert line.startswith("error: ")
    assert "parameters.E.high" in line and "20000" in line and "30000" in line, line
    assert "output.dir" in line and "--restart" in line and "kept" in line, line
    assert "restart=True" not in line and "overwrite=True" not in line
    assert chains.read_bytes() == before
    # fit's own refusal is worded for the command line too
    code = cli.main(["fit", "--quiet", str(run)])
    err = capsys.readouterr().err
    assert code == 2 and "--force" in err and "overwrite=True" not in err and "parameters.E.high" in err


def test_changed_data_content_is_named(run: Path, capsys) -> None:
    assert _sample(run, capsys)[0] == 0
    data = run.parent / "data.csv"
    lines = data.read_text().splitlines()
    cells = lines[50].split(",")
    cells[-1] = str(float(cells[-1]) + 1.0)
    lines[50] = ",".join(cells)
    data.write_text("\n".join(lines) + "\n")
    code, text = _sample(run, capsys)
    assert code == 2 and "data file changed" in text and "data.csv" in text, text
    assert "--restart" in text and "output.dir" in text


def test_same_bytes_under_a_new_mtime_is_the_same_run(run: Path, capsys) -> None:
    """The size and mtime are a shortcut only: a file touched (or copied back) is hashed again and
    found the same."""
    assert _sample(run, capsys)[0] == 0
    data = run.parent / "data.csv"
    os.utime(data, ns=(1_000_000_000, 1_000_000_000))
    _edit(run, sampler__max_steps=40)
    code, text = _sample(run, capsys)
    assert code == 0, text
    assert read_run(run.parent / "chains.h5").steps == 40


def test_data_digest_shortcut(run: Path, capsys, monkeypatch) -> None:
    """Same resolved path, size and mtime as recorded: the recorded digest, the file not read."""
    from bayes_dnlr.runs import identity

    assert _sample(run, capsys)[0] == 0
    cfg = load_config(run)
    summary = json.loads((run.parent / "summary.json").read_text())
    calls = []
    real = identity.file_sha256
    monkeypatch.setattr(identity, "file_sha256", lambda p: calls.append(p) or real(p))
    sha = identity.data_sha(cfg, summary)
    assert sha == summary["data_sha256"] and calls == []
    os.utime(run.parent / "data.csv", ns=(5, 5))
    assert identity.data_sha(cfg, summary) == sha and len(calls) == 1


# ---------------------------------------------------------------- results of the previous version

def _to_previous_form(run_dir: Path, cfg) -> None:
    """Rewrite fit.json's and chains.h5's fingerprints as the previous version wrote them: section
    digests of the config as dumped (data.file as spelt), no identity record."""
    fit_path = run_dir / "fit.json"
    fit = json.loads(fit_path.read_text())
    fit_secs = ("data", "model", "parameters", "noise", "fit")
    fit["config_digest"] = legacy_config_digest(cfg, fit_secs)
    fit["config_sections"] = legacy_section_digests(cfg, fit_secs)
    fit.pop("identity", None)
    fit_path.write_text(json.dumps(fit))
    from bayes_dnlr.digests import digest

    parts = legacy_section_digests(cfg, ("data", "model", "parameters", "noise"))
    sampler = cfg.sampler.model_dump(mode="json")
    parts["sampler"] = digest({k: sampler[k] for k in ("walkers", "seed", "moves")})
    parts["data file"] = fit["data_sha256"]
    with h5py.File(run_dir / "chains.h5", "r+") as f:
        f.attrs["fingerprint_parts"] = json.dumps(parts)
        f.attrs["fingerprint"] = digest(parts)
        if "identity" in f.attrs:
            del f.attrs["identity"]
    summary_path = run_dir / "summary.json"
    summary = json.loads(summary_path.read_text())
    summary["fingerprint"] = digest(parts)
    summary.pop("identity", None)
    summary_path.write_text(json.dumps(summary))


@pytest.mark.parametrize("respell", [None, "./data.csv", "absolute"])
def test_chain_of_the_previous_form_continues(run: Path, capsys, respell: str | None) -> None:
    assert _sample(run, capsys)[0] == 0
    _to_previous_form(run.parent, load_config(run))
    first = read_run(run.parent / "chains.h5")
    fit_before = (run.parent / "fit.json").read_text()
    if respell is not None:
        _edit(run, data__file=str(run.parent / "data.csv") if respell == "absolute" else respell)
    _edit(run, sampler__max_steps=40)
    code, text = _sample(run, capsys)
    assert code == 0, text
    stored = read_run(run.parent / "chains.h5")
    assert stored.steps == 40
    np.testing.assert_array_equal(stored.chain[:20], first.chain)
    assert (run.parent / "fit.json").read_text() == fit_before     # not redone


def test_chain_of_the_previous_form_still_refuses_real_changes(run: Path, capsys) -> None:
    assert _sample(run, capsys)[0] == 0
    _to_previous_form(run.parent, load_config(run))
    _edit(run, data__file="./data.csv", parameters__E__high=30000)
    code, text = _sample(run, capsys)
    assert code == 2 and "parameters" in text and "--restart" in text, text


def test_batch_reuses_a_finished_test_of_the_previous_form(tmp_path: Path, capsys) -> None:
    template, manifest = tiny_campaign(tmp_path, 2, points=150, sampler=FEW)
    out = tmp_path / "out"
    args = ["batch", str(template), "--manifest", str(manifest), "--out", str(out), "--jobs", "1",
            "--no-report", "--no-population", "--quiet"]
    assert cli.main(args) == 0
    for name in ("t0", "t1"):
        _to_previous_form(out / "runs" / name, load_config(out / "runs" / name / "config.yaml"))
        row = json.loads((out / "rows" / f"{name}.json").read_text())
        row["fingerprint"] = {"chain": json.loads((out / "runs" / name / "summary.json").read_text())
                              ["fingerprint"], "settings": row["fingerprint"]["settings"]}
        (out / "rows" / f"{name}.json").write_text(json.dumps(row))
    capsys.readouterr()
    assert cli.main(args) == 0
    assert "2 already done" in capsys.readouterr().out


def test_moved_run_folder_is_the_same_run(run: Path, tmp_path: Path, capsys) -> None:
    """The data's content, not its place, is the identity: a project moved with its data keeps its
    chains."""
    assert _sample(run, capsys)[0] == 0
    moved = tmp_path / "elsewhere" / "syn"
    shutil.copytree(run.parent, moved)
    config = moved / "config.yaml"
    _edit(config, sampler__max_steps=40)
    code, text = _sample(config, capsys)
    assert code == 0, text
    assert read_run(moved / "chains.h5").steps == 40


def _as_if_made_before_data_reduce(run_dir: Path) -> None:
    """Rewrite a run's fit.json and chain as a version without the ``data.reduce`` key wrote them:
    the key absent from the stored values, and other digests of the data section."""
    fit_path = run_dir / "fit.json"
    saved = json.loads(fit_path.read_text())
    saved["identity"]["values"]["data"].pop("reduce")
    saved["config_sections"]["data"] = "0" * 64
    saved["config_digest"] = "1" * 64
    fit_path.write_text(json.dumps(saved))
    with h5py.File(run_dir / "chains.h5", "r+") as h:
        record = json.loads(h.attrs["identity"])
        record["values"]["data"].pop("reduce")
        h.attrs["identity"] = json.dumps(record)
        parts = json.loads(h.attrs["fingerprint_parts"])
        parts["data"] = "2" * 64
        h.attrs["fingerprint_parts"] = json.dumps(parts)


def test_a_key_a_newer_version_added_at_its_default_keeps_the_results(run: Path, capsys) -> None:
    """A result made before a config key existed belongs to a config that leaves the key at its
    default; set to another value, the key is a real change."""
    from bayes_dnlr.runs.fit import fit_is_current

    assert _sample(run, capsys)[0] == 0
    _as_if_made_before_data_reduce(run.parent)
    assert fit_is_current(load_config(run))
    _edit(run, sampler__max_steps=40)                 # continue the chain: it must not be refused
    code, text = _sample(run, capsys)
    assert code == 0, text
    _edit(run, data__reduce="none")
    code, text = _sample(run, capsys)
    assert code == 2 and "data.reduce" in text, text


def test_a_noise_change_stales_the_chain_even_after_a_new_fit(run: Path, capsys) -> None:
    """The likelihood is part of what a chain was sampled from: a chain sampled with one ``noise:``
    is never continued under another, even once fit.json has been redone for the new one."""
    from bayes_dnlr.runs.chains import read_attrs
    from bayes_dnlr.runs.identity import chain_stale_reason, data_sha

    assert _sample(run, capsys)[0] == 0
    chains = run.parent / "chains.h5"
    before = chains.read_bytes()
    _edit(run, noise__sigma0=0.5)
    assert cli.main(["fit", "--quiet", "--force", str(run)]) == 0
    capsys.readouterr()
    code, text = _sample(run, capsys)
    assert code == 2, text
    assert "noise" in text and "noise.sigma0: 0.3 -> 0.5" in text and "--restart" in text, text
    assert chains.read_bytes() == before
    cfg = load_config(run)
    reason = chain_stale_reason(read_attrs(chains), cfg, data_sha(cfg), run.parent)
    assert reason is not None and "config section(s) noise changed" in reason, reason
