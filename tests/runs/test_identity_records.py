"""A run's identity records and the reasons a stored result is stale (runs/identity.py), on configs
and records made in memory: no fit, no chain. tests/runs/test_identity.py drives the same through
`fit` and `sample`; here each rule is checked alone, fast enough to test every change of it."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from bayes_dnlr.config import parse_config
from bayes_dnlr.digests import digest, file_sha256
from bayes_dnlr.runs import identity
from bayes_dnlr.runs.folder import section_digests as legacy_section_digests
from bayes_dnlr.runs.testset import load_tests, sections

COLUMNS = {"time": "t", "strain": "e", "stress": "s"}


def _data(folder: Path, name: str = "d.csv", shift: float = 0.0) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    t = np.linspace(0.0, 10.0, 30)
    np.savetxt(folder / name, np.column_stack([t, 1e-3 * t, 2.0 * t + shift]), delimiter=",",
               header="t,e,s", comments="")
    return folder / name


def _config(folder: Path, *, file: str = "d.csv", noise: dict | None = None, sampler: dict | None = None,
            parameters: dict | None = None, tests: list[str] | None = None, sigma0s: tuple = (0.3, 0.3)):
    raw: dict = {"name": "run", "sampler": {"walkers": 8, "seed": 1, **(sampler or {})}}
    if tests is None:
        raw["data"] = {"file": file, "columns": COLUMNS, "observable": "stress"}
        raw["noise"] = noise or {"sigma0": 0.3, "discrepancy": "none"}
    else:
        raw["tests"] = [{"name": Path(f).stem,
                         "data": {"file": f, "columns": COLUMNS, "observable": "stress"},
                         "noise": {"sigma0": s0, "discrepancy": "none"}}
                        for f, s0 in zip(tests, sigma0s, strict=False)]
    if parameters is not None:
        raw["parameters"] = parameters
    return parse_config(raw, source=folder / "config.yaml")


def _stored_chain(cfg) -> dict:
    """The attributes a chain sampled from ``cfg`` carries (runs/sample.py)."""
    tests = load_tests(cfg)
    return {"fingerprint_parts": json.dumps(identity.chain_parts(cfg, tests.sha256)),
            "fingerprint": digest(identity.chain_parts(cfg, tests.sha256)),
            "identity": identity.chain_record(cfg, tests, identity.stat_data(cfg))}


def _saved_fit(cfg) -> dict:
    """fit.json's identity fields for ``cfg`` (runs/fit.py)."""
    tests = load_tests(cfg)
    secs = sections(cfg)
    return {"config_digest": identity.config_digest(cfg, secs),
            "config_sections": identity.section_digests(cfg, secs), "data_sha256": tests.sha256,
            "identity": identity.fit_record(cfg, secs, tests, identity.stat_data(cfg))}


def _reason(attrs: dict, cfg) -> str | None:
    return identity.chain_stale_reason(attrs, cfg, identity.data_sha(cfg), cfg.base_dir)


def test_the_same_config_and_data_keep_the_chain(tmp_path: Path) -> None:
    _data(tmp_path)
    cfg = _config(tmp_path)
    attrs = _stored_chain(cfg)
    assert _reason(attrs, cfg) is None
    assert _reason(attrs, _config(tmp_path, file=str(tmp_path / "d.csv"))) is None   # spelt absolute
    assert identity.chain_fingerprint(cfg, tmp_path, identity.data_sha(cfg)) == attrs["fingerprint"]


@pytest.mark.parametrize(("change", "words"), [
    ({"noise": {"sigma0": 0.5, "discrepancy": "none"}},
     "config section(s) noise changed (noise.sigma0: 0.3 -> 0.5)"),
    ({"sampler": {"seed": 2}}, "config section(s) sampler.walkers/seed/moves changed (sampler.seed: 1 -> 2)"),
    ({"parameters": {"E": {"prior": "uniform", "low": 100, "high": 9000}}},
     "config section(s) parameters changed (parameters.E.high: 20000.0 -> 9000.0)"),
])
def test_each_part_of_a_chains_identity_stales_it_and_is_named(tmp_path: Path, change, words) -> None:
    _data(tmp_path)
    base = {"parameters": {"E": {"prior": "uniform", "low": 100, "high": 20000}}}
    attrs = _stored_chain(_config(tmp_path, **base))
    assert _reason(attrs, _config(tmp_path, **(base | change))) == words


def _uniform(low: float, high: float) -> dict:
    return {"prior": "uniform", "low": low, "high": high}


def test_many_changed_keys_are_counted_beyond_the_first_three(tmp_path: Path) -> None:
    _data(tmp_path)
    base = {"E": _uniform(100, 20000), "G": _uniform(0, 5)}
    attrs = _stored_chain(_config(tmp_path, parameters=base))
    changed = {"E": _uniform(200, 30000), "G": _uniform(1, 6)}
    reason = _reason(attrs, _config(tmp_path, parameters=changed))
    assert reason.endswith(", and 1 more)") and reason.count(" -> ") == 3, reason
    three = {"E": _uniform(200, 30000), "G": _uniform(1, 5)}
    reason = _reason(attrs, _config(tmp_path, parameters=three))
    assert "more" not in reason and reason.count(" -> ") == 3 and reason.endswith("-> 1.0)"), reason


def test_a_new_data_content_is_named_with_the_file_it_was_made_from(tmp_path: Path) -> None:
    _data(tmp_path)
    attrs = _stored_chain(_config(tmp_path))
    _data(tmp_path, "other.csv", shift=1.0)
    reason = _reason(attrs, _config(tmp_path, file="other.csv"))
    assert reason == (f"the data file changed ({tmp_path / 'other.csv'}: sha256 differs; it was made "
                      f"from {tmp_path / 'd.csv'})")
    _data(tmp_path, shift=2.0)                    # the same file, new content: no "made from"
    same = _reason(attrs, _config(tmp_path))
    assert same == f"the data file changed ({tmp_path / 'd.csv'}: sha256 differs)"
    both = _reason(attrs, _config(tmp_path, noise={"sigma0": 0.4, "discrepancy": "none"}))
    assert both.startswith("config section(s) noise changed") and " and the data file changed (" in both


def test_a_saved_fit_is_stale_for_another_config_or_data(tmp_path: Path) -> None:
    _data(tmp_path)
    cfg = _config(tmp_path)
    saved = _saved_fit(cfg)
    sha = identity.data_sha(cfg)
    assert identity.fit_stale_reason(saved, cfg, sections(cfg), sha, tmp_path) is None
    noisy = _config(tmp_path, noise={"sigma0": 0.5, "discrepancy": "none"})
    assert identity.fit_stale_reason(saved, noisy, sections(noisy), sha, tmp_path) == (
        "a different config (sections noise (noise.sigma0: 0.3 -> 0.5))")
    other = identity.fit_stale_reason(saved, cfg, sections(cfg), "f" * 64, tmp_path)
    assert other == f"a different data file ({tmp_path / 'd.csv'}: sha256 differs)"
    # a fit.json without section digests names every section it depends on
    bare = {k: v for k, v in saved.items() if k not in ("config_sections", "identity")}
    bare["config_digest"] = "x"
    assert identity.fit_stale_reason(bare, cfg, sections(cfg), sha, tmp_path) == (
        "a different config (sections data, model, parameters, noise, fit)")


def test_fit_is_current_reads_fit_json_in_the_run_folder(tmp_path: Path) -> None:
    _data(tmp_path)
    cfg = _config(tmp_path)
    assert not identity.fit_is_current(cfg)
    assert identity.stale_fit_reason(cfg, identity.data_sha(cfg)) is None       # no fit.json: nothing stale
    cfg.run_dir.mkdir(parents=True, exist_ok=True)
    (cfg.run_dir / "fit.json").write_text(json.dumps(_saved_fit(cfg)))
    assert identity.fit_is_current(cfg)
    noisy = _config(tmp_path, noise={"sigma0": 0.5, "discrepancy": "none"})
    assert not identity.fit_is_current(noisy)
    assert "noise.sigma0: 0.3 -> 0.5" in identity.stale_fit_reason(noisy, identity.data_sha(noisy))
    (cfg.run_dir / "fit.json").write_text("{not json")
    assert not identity.fit_is_current(cfg)
    assert identity.stale_fit_reason(cfg, identity.data_sha(cfg)).startswith("an unreadable file (")


def test_the_data_digest_is_the_recorded_one_only_for_the_same_path_size_and_mtime(tmp_path, monkeypatch):
    path = _data(tmp_path)
    cfg = _config(tmp_path)
    sha = file_sha256(path)
    name = cfg.test_names[0]
    record = identity.data_record(cfg, load_tests(cfg), identity.stat_data(cfg))
    assert record["data_files"][name]["sha256"] == sha and record["data_files"][name]["mtime_ns"] is not None
    fake = dict(record)
    fake["data_files"] = {name: {**record["data_files"][name], "sha256": "a" * 64}}
    assert identity.data_sha(cfg, {"identity": fake}) == "a" * 64         # taken without reading the file
    assert identity.data_sha(cfg, {"identity": json.dumps(fake)}) == "a" * 64
    os.utime(path, ns=(7, 7))
    assert identity.data_sha(cfg, {"identity": fake}) == sha               # another mtime: hashed again
    no_mtime = {"data_files": {name: {**fake["data_files"][name], "mtime_ns": None}}}
    assert identity.data_sha(cfg, {"identity": no_mtime}) == sha
    # a file that changed while it was read is recorded without its mtime
    changed = identity.data_record(cfg, load_tests(cfg), {name: ("elsewhere", 1, 2)})
    assert changed["data_files"][name]["mtime_ns"] is None
    path.unlink()
    assert identity.data_sha(cfg) is None and identity.stat_data(cfg) is None


def test_a_run_of_several_tests_digests_all_its_files(tmp_path: Path) -> None:
    a, b = _data(tmp_path, "a.csv"), _data(tmp_path, "b.csv", shift=1.0)
    cfg = _config(tmp_path, tests=["a.csv", "b.csv"])
    shas = {"a": file_sha256(a), "b": file_sha256(b)}
    assert identity.data_sha(cfg) == digest(shas) == identity.combined_sha(cfg, shas)
    assert identity.data_sha(cfg) != shas["a"]
    attrs = _stored_chain(cfg)
    assert _reason(attrs, cfg) is None
    _data(tmp_path, "b.csv", shift=3.0)
    assert _reason(attrs, cfg).startswith("the data file changed (")


def _previous_form_chain(cfg, spelt: str) -> dict:
    """A chain's attributes as the previous version wrote them, its config spelling the data file
    ``spelt``: section digests of the config as dumped, no identity record."""
    old = _config(cfg.base_dir, file=spelt)
    parts = legacy_section_digests(old, ("data", "model", "parameters", "noise"))
    parts["sampler"] = digest({k: old.sampler.model_dump(mode="json")[k] for k in identity.SAMPLER_KEYS})
    parts[identity.DATA_FILE] = identity.data_sha(cfg)
    return {"fingerprint_parts": json.dumps(parts), "fingerprint": digest(parts),
            "config": json.dumps(old.model_dump(mode="json"))}


@pytest.mark.parametrize("spelt", ["d.csv", "./d.csv", "absolute", "from the run folder"])
def test_a_chain_of_the_previous_form_continues_under_any_spelling_of_its_file(tmp_path, spelt) -> None:
    """Made with one spelling of the data file, read with another (here ../proj/d.csv from a
    sibling folder): every spelling of the same file is the same run."""
    _data(tmp_path / "proj")
    now = _config(tmp_path / "proj", file="../proj/d.csv")
    path = tmp_path / "proj" / "d.csv"
    spelling = {"absolute": str(path),
                "from the run folder": os.path.relpath(path, now.run_dir)}.get(spelt, spelt)
    attrs = _previous_form_chain(now, spelling)
    assert identity.chain_stale_reason(attrs, now, identity.data_sha(now), now.run_dir) is None
    assert identity.chain_fingerprint(now, now.run_dir, identity.data_sha(now)) != attrs["fingerprint"]
    # a real change is still one, named from the config the chain kept
    noisy = _config(tmp_path / "proj", file="../proj/d.csv", noise={"sigma0": 0.6, "discrepancy": "none"})
    reason = identity.chain_stale_reason(attrs, noisy, identity.data_sha(noisy), noisy.run_dir)
    assert reason == "config section(s) noise changed (noise.sigma0: 0.3 -> 0.6)", reason
    seed = _config(tmp_path / "proj", file="../proj/d.csv", sampler={"seed": 5})
    reason = identity.chain_stale_reason(attrs, seed, identity.data_sha(seed), seed.run_dir)
    assert reason == "config section(s) sampler.walkers/seed/moves changed (sampler.seed: 1 -> 5)", reason


def test_a_key_a_newer_version_added_keeps_a_result_only_at_its_default(tmp_path: Path) -> None:
    _data(tmp_path)
    cfg = _config(tmp_path)
    attrs = _stored_chain(cfg)
    record = json.loads(attrs["identity"])
    record["values"]["data"].pop("reduce")              # a chain of a version without data.reduce
    parts = json.loads(attrs["fingerprint_parts"])
    parts["data"] = "0" * 64
    older = {**attrs, "identity": json.dumps(record), "fingerprint_parts": json.dumps(parts)}
    assert _reason(older, cfg) is None
    raw_reduce = _config(tmp_path)
    reduced = parse_config({**json.loads(json.dumps(raw_reduce.model_dump(mode="json", exclude_none=True))),
                            "data": {"file": "d.csv", "columns": COLUMNS, "observable": "stress",
                                     "reduce": "none"}}, source=tmp_path / "config.yaml")
    assert "data.reduce: (not set) -> none" in _reason(older, reduced)
    # a key the stored record has, changed, is a change even when the new value is a default
    record["values"]["noise"]["sigma0"] = 0.7
    parts["noise"] = "1" * 64
    changed = {**attrs, "identity": json.dumps(record), "fingerprint_parts": json.dumps(parts)}
    assert _reason(changed, cfg) == "config section(s) noise changed (noise.sigma0: 0.7 -> 0.3)"


def test_a_stored_fingerprint_is_kept_only_for_a_current_chain(tmp_path: Path) -> None:
    from bayes_dnlr.runs.chains import read_attrs  # noqa: F401  (the reader chain_fingerprint uses)

    _data(tmp_path)
    cfg = _config(tmp_path)
    sha = identity.data_sha(cfg)
    new = digest(identity.chain_parts(cfg, sha))
    assert identity.chain_fingerprint(cfg, tmp_path, sha, {"fingerprint": new}) == new
    assert identity.chain_fingerprint(cfg, tmp_path, sha, {"fingerprint": "old"}) == new    # no chain file


def test_the_tests_of_a_run_are_compared_without_their_files_spelling(tmp_path: Path) -> None:
    _data(tmp_path, "a.csv")
    _data(tmp_path, "b.csv", shift=1.0)
    cfg = _config(tmp_path, tests=["a.csv", "b.csv"])
    values = identity.section_values(cfg, ("tests",))["tests"]
    assert all("file" not in t["data"] and t["data"]["columns"]["stress"] == "s" for t in values)
    attrs = _stored_chain(cfg)
    assert _reason(attrs, _config(tmp_path, tests=["./a.csv", str(tmp_path / "b.csv")])) is None
    reason = _reason(attrs, _config(tmp_path, tests=["a.csv", "b.csv"], sigma0s=(0.3, 0.4)))
    assert reason == "config section(s) tests changed (tests[1].noise.sigma0: 0.3 -> 0.4)", reason
    # a key a newer version added inside a test, at its default, keeps the chain current; the
    # same record with that key at another value does not
    record = json.loads(attrs["identity"])
    record["values"]["tests"][0]["data"].pop("reduce")
    parts = json.loads(attrs["fingerprint_parts"])
    parts["tests"] = "0" * 64
    older = {**attrs, "identity": json.dumps(record), "fingerprint_parts": json.dumps(parts)}
    assert _reason(older, cfg) is None
    record["values"]["tests"][0]["data"]["reduce"] = "none"
    other = {**older, "identity": json.dumps(record)}
    assert _reason(other, cfg) == "config section(s) tests changed (tests[0].data.reduce: none -> auto)"


def test_the_fingerprint_of_a_current_chain_is_the_one_it_carries(tmp_path: Path, monkeypatch) -> None:
    """A chain of the previous form keeps its own fingerprint in the outputs; a stale one, one
    without a fingerprint or one that cannot be read gives way to the new form's."""
    from bayes_dnlr.runs import chains

    _data(tmp_path)
    cfg = _config(tmp_path)
    sha = identity.data_sha(cfg)
    new = digest(identity.chain_parts(cfg, sha))
    legacy = _previous_form_chain(cfg, "d.csv")
    assert legacy["fingerprint"] != new
    stored: dict = {}

    def read_attrs(path):
        assert Path(path) == tmp_path / "chains.h5"
        if isinstance(stored.get("error"), Exception):
            raise stored["error"]
        return stored

    monkeypatch.setattr(chains, "read_attrs", read_attrs)
    stored.update(legacy)
    assert identity.chain_fingerprint(cfg, tmp_path, sha) == legacy["fingerprint"]
    assert identity.chain_fingerprint(cfg, tmp_path, sha, {"fingerprint": "other"}) == legacy["fingerprint"]
    assert identity.chain_fingerprint(cfg, tmp_path, sha, {"fingerprint": new}) == new   # file not read
    noisy = _config(tmp_path, noise={"sigma0": 0.9, "discrepancy": "none"})
    assert identity.chain_fingerprint(noisy, tmp_path, sha) == digest(identity.chain_parts(noisy, sha))
    stored.pop("fingerprint")
    assert identity.chain_fingerprint(cfg, tmp_path, sha) == new
    stored["error"] = OSError("unreadable")
    assert identity.chain_fingerprint(cfg, tmp_path, sha) == new


def test_a_chain_of_the_previous_form_with_other_data_or_sampler_is_stale(tmp_path: Path) -> None:
    _data(tmp_path)
    cfg = _config(tmp_path)
    legacy = _previous_form_chain(cfg, "d.csv")
    parts = json.loads(legacy["fingerprint_parts"])
    parts[identity.DATA_FILE] = "e" * 64
    other = {**legacy, "fingerprint_parts": json.dumps(parts)}
    assert _reason(other, cfg) == f"the data file changed ({tmp_path / 'd.csv'}: sha256 differs)"
    # an identity record that is not JSON is a record of the previous form
    assert _reason({**legacy, "identity": "not json"}, cfg) is None
    # no parts at all: every section is named
    assert _reason({}, cfg) == ("config section(s) data, model, parameters, noise, "
                                "sampler.walkers/seed/moves changed and the data file changed "
                                f"({tmp_path / 'd.csv'}: sha256 differs)")


def test_a_fit_of_the_previous_form_is_current_under_any_spelling_and_stale_for_a_change(tmp_path):
    _data(tmp_path / "proj")
    now = _config(tmp_path / "proj", file="../proj/d.csv")
    secs = sections(now)
    sha = identity.data_sha(now)
    old = _config(tmp_path / "proj", file="./d.csv")
    saved = {"config_sections": legacy_section_digests(old, secs), "config_digest": "legacy",
             "data_sha256": sha}
    assert identity.fit_stale_reason(saved, now, secs, sha, now.run_dir) is None
    noisy = _config(tmp_path / "proj", file="../proj/d.csv", noise={"sigma0": 0.6, "discrepancy": "none"})
    assert identity.fit_stale_reason(saved, noisy, secs, sha, noisy.run_dir) == (
        "a different config (sections noise)")
    assert identity.fit_stale_reason({"data_sha256": sha}, now, secs, sha, now.run_dir) == (
        "a different config (sections data, model, parameters, noise, fit)")
    # the data file named in the reason is the one the fit recorded
    record = identity.fit_record(now, secs, load_tests(now), identity.stat_data(now))
    moved = {**saved, "identity": record, "data_sha256": "0" * 64}
    moved["identity"]["data_files"][now.test_names[0]]["path"] = "/elsewhere/d.csv"
    reason = identity.fit_stale_reason(moved, now, secs, sha, now.run_dir)
    assert reason.endswith("a different data file (" + str(now.data_path) + ": sha256 differs; it was made "
                           "from /elsewhere/d.csv)"), reason


def test_fit_json_with_other_data_or_none_at_all(tmp_path: Path) -> None:
    path = _data(tmp_path)
    cfg = _config(tmp_path)
    cfg.run_dir.mkdir(parents=True, exist_ok=True)
    (cfg.run_dir / "fit.json").write_text(json.dumps(_saved_fit(cfg)))
    assert identity.stale_fit_reason(cfg, "f" * 64) == f"a different data file ({path}: sha256 differs)"
    assert not identity.fit_is_current(cfg, "f" * 64)
    path.unlink()
    assert not identity.fit_is_current(cfg)                 # no data file: nothing is current
