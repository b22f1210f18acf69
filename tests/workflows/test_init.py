"""init: a starting config from an export; `fit` accepts it after at most the edits init lists.
The real curves are read from ../shared/data/real (or $BAYES_DNLR_REAL_DATA) and the
tests that need them skip when the folder is absent; the Bluehill-like export ships in runs/."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
import yaml
from support import REPO
from support.real_data import ETFE, REAL_MARKS, RHDPE

from bayes_dnlr.cli import main
from bayes_dnlr.config import load_config
from bayes_dnlr.workflows.init import init_config

BLUEHILL = REPO / "runs/bluehill-like/bluehill-like.csv"
real = list(REAL_MARKS)

# What the user knows about each test (the data README, the shipped config): the value of a key when
# init lists it. A key init does not list is never touched.
KNOWN: dict[str, dict[str, Any]] = {
    "bluehill": {"data.area0": 40.0, "data.strain_measure": "nominal"},
    "rhdpe": {},
    "etfe": {"data.specimen": 1},
}
# the keys the file cannot tell (so init must list them as values to set), and E's plausible range
NEEDED = {"bluehill": {"data.area0"}, "rhdpe": set(), "etfe": set()}
E_RANGE = {"bluehill": (2700, 3000), "rhdpe": (1000, 8000), "etfe": (1500, 3000)}


def _set(raw: dict, key: str, value: Any) -> None:
    *path, last = key.split(".")
    node = raw
    for k in path:
        node = node.setdefault(k, {})
    node[last] = value


@pytest.mark.parametrize("case", ["bluehill", pytest.param("rhdpe", marks=real),
                                  pytest.param("etfe", marks=real)])
def test_fit_accepts_the_config_after_the_listed_edits(tmp_path, case):
    from bayes_dnlr.runs.fit import fit

    data = {"bluehill": BLUEHILL, "rhdpe": RHDPE, "etfe": ETFE}[case]
    out = tmp_path / case / "config.yaml"
    result = init_config(data, out)
    to_set = {e.key for e in result.edits if e.action == "set"}
    assert to_set == NEEDED[case]
    assert not result.problems or all("cannot be read" not in p for p in result.problems)
    if to_set:
        with pytest.raises(Exception):              # noqa: B017 - as written, a value is missing
            fit(load_config(out), write=False)
    raw = yaml.safe_load(out.read_text())
    for e in result.edits:                          # exactly the listed edits, with what the user knows
        if e.key in KNOWN[case]:
            _set(raw, e.key, KNOWN[case][e.key])
        else:
            assert e.action == "check", f"{e.key}: init asks for a value the test does not know"
    out.write_text(yaml.safe_dump(raw, sort_keys=False))
    r = fit(load_config(out), write=False).only
    assert r.converged
    lo, hi = E_RANGE[case]
    assert lo < r.estimate["E"] < hi, r.estimate


def test_headers_and_units_are_read_and_only_the_area_is_asked(tmp_path):
    result = init_config(BLUEHILL, tmp_path / "bh" / "config.yaml")
    d = result.raw["data"]
    assert d["columns"] == {"time": "Time", "force": "Load", "strain": "Tensile strain"}
    assert "units" not in d and "strain_unit" not in d          # read from the units row
    assert [e.key for e in result.edits if e.action == "set"] == ["data.area0"]
    assert d["window"]["strain_max"] == pytest.approx(0.087, abs=0.01)   # the force peak (yield)
    text = (tmp_path / "bh" / "config.yaml").read_text()
    assert "area0: null   # EDIT" in text and text.startswith("# Starting config")


def test_cli_prints_the_edits_and_never_overwrites(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["init", str(BLUEHILL)]) == 0
    out = capsys.readouterr().out
    cfg = Path("runs/bluehill-like/config.yaml")
    assert out.startswith(f"wrote {cfg} (a starting config)")
    assert "1. set   data.area0" in out and "before `python -m bayes_dnlr fit" in out
    before = cfg.read_text()
    assert main(["init", str(BLUEHILL)]) == 2
    assert capsys.readouterr().err == (f"error: {cfg}: exists; init never overwrites a config "
                                       "(give --out another path)\n")
    assert cfg.read_text() == before
    assert main(["init", str(BLUEHILL), "--out", "runs/bluehill-like"]) == 2     # a folder, not a file
    assert capsys.readouterr().err == ("error: runs/bluehill-like: --out names the config file to "
                                       "write, e.g. runs/name/config.yaml\n")
    assert main(["init", "nope.csv"]) == 2
    assert "nope.csv: data file not found" in capsys.readouterr().err
    assert sorted(p.name for p in Path("runs/bluehill-like").iterdir()) == ["config.yaml"]


def test_extension_in_mm_and_force_in_kn_ask_for_gauge_length_and_area(tmp_path):
    """A header with units in the names: the extension needs L0 and the force S0; after those two
    values (and nothing else), fit finds the true E."""
    import numpy as np

    from bayes_dnlr.model import simulate
    from bayes_dnlr.runs.fit import fit

    truth = {"E": 2854.0, "G": 2.32, "tau_max": 5.79}
    t = np.linspace(0.0, 200.0, 801)
    eps = 5e-3 * t                                          # Hencky strain at 5e-3 1/s
    sigma = simulate(t, eps, truth)                         # true stress σ*, MPa
    rng = np.random.default_rng(3)
    ext = 50.0 * np.expm1(eps)                              # mm on L0 = 50 mm
    force = (sigma + rng.normal(0, 0.3, t.size)) * 40.0 * np.exp(-eps) / 1000.0   # kN on S0 = 40 mm²
    csv = tmp_path / "export.csv"
    np.savetxt(csv, np.column_stack([t, ext, force]), delimiter=",", comments="",
               header="Time (s),Extension (mm),Load (kN)")
    out = tmp_path / "ext" / "config.yaml"
    result = init_config(csv, out)
    d = result.raw["data"]
    assert d["columns"] == {"time": "Time (s)", "force": "Load (kN)", "extension": "Extension (mm)"}
    assert [e.key for e in result.edits if e.action == "set"] == ["data.gauge_length", "data.area0"]
    assert "units" not in d                                 # s, mm and kN read from the header
    raw = yaml.safe_load(out.read_text())
    raw["data"].update(gauge_length=50.0, area0=40.0)
    raw["data"]["window"] = {}                              # the check: the whole test (homogeneous)
    out.write_text(yaml.safe_dump(raw, sort_keys=False))
    r = fit(load_config(out), write=False).only
    assert r.converged and abs(r.estimate["E"] - truth["E"]) < 3 * r.sd["E"], (r.estimate, r.sd)


def test_a_relaxation_hold_is_seen_and_the_window_keeps_it(tmp_path):
    """The shipped ramp-and-hold example: relaxation_start: auto is written with the computed
    relation that confirms it (no check line), the window is the whole test, and fit accepts it
    after the area (and the strain measure of eps11)."""
    from bayes_dnlr.runs.fit import fit

    out = tmp_path / "relax" / "config.yaml"
    result = init_config(REPO / "runs/hdpe-b-relax-5e-3/hdpe-b-relax-5e-3.csv", out)
    d = result.raw["data"]
    assert d["relaxation_start"] == "auto" and d["window"] == {}
    assert d["units"] == {"time": "s", "force": "N"}                 # from the names t_s and F_N
    keys = {e.key for e in result.edits}
    assert {"data.area0", "data.strain_measure"} <= keys and "data.relaxation_start" not in keys
    text = out.read_text()          # the hold is confirmed (the strain stays, the stress falls)
    assert "relaxation_start: auto   # a relaxation hold: 'eps11' stays at 2" in text
    raw = yaml.safe_load(out.read_text())
    raw["data"].update(area0=24.0, strain_measure="hencky")          # the shipped config's values
    out.write_text(yaml.safe_dump(raw, sort_keys=False))
    r = fit(load_config(out), write=False).only
    assert r.converged and {"sigma_inf", "tau_max_R"} <= set(r.estimate)
    assert abs(r.estimate["E"] - 2270.0) < 4 * r.sd["E"], (r.estimate, r.sd)


@pytest.mark.parametrize("name", ["line\nbreak.csv", "tab\there.csv", "quote\"and'#hash: x.csv",
                                  "nel\x85ls\u2028ps\u2029.csv", "bell\x07{a: [b]}.csv"])
def test_names_that_reach_the_config_are_escaped(tmp_path, name):
    """A file name with a newline (or any control or YAML-special character) goes into the config's
    comments and data.file: the config stays valid YAML, reads back the same name and fits."""
    import numpy as np

    t = np.linspace(0.0, 100.0, 201)
    csv = tmp_path / name
    header = "Time (s),Strain #1 (%),Stress: true\tx (MPa)"
    rows = [f"{a:.6g},{0.5 * a:.6g},{50 * (1 - np.exp(-a / 10)):.6g}" for a in t]
    csv.write_text("\n".join([header, *rows]) + "\n")
    out = tmp_path / "run" / "config.yaml"
    init_config(csv, out)
    raw = yaml.safe_load(out.read_text())                 # valid YAML
    cfg = load_config(out)
    assert cfg.data_path.resolve() == csv.resolve()
    assert raw["data"]["columns"]["stress"] == "Stress: true\tx (MPa)"
    assert all("\n" not in line and "\x85" not in line for line in out.read_text().split("\n"))


def _cropped(tmp_path: Path, rows: int, zeroed: bool) -> Path:
    """The Bluehill-like export without its first ``rows`` samples; ``zeroed``: its strain also
    counted from the new first sample (a preload), else from the unloaded length (a cropped toe)."""
    lines = BLUEHILL.read_text().splitlines(keepends=True)
    start = lines.index('"(s)","(%)","(N)"\n') + 1
    kept = [line for line in lines[start + rows:] if line.strip()]
    if zeroed:
        cells = [line.strip().strip('"').split('","') for line in kept]
        e0 = float(cells[0][1])
        kept = [f'"{t}","{float(e) - e0:.10g}","{f}"\n' for t, e, f in cells]
    path = tmp_path / f"{'preload' if zeroed else 'cropped'}.csv"
    path.write_text("".join(lines[:start] + kept))
    return path


def _fit_e(out: Path, **data) -> float:
    from bayes_dnlr.runs.fit import fit

    raw = yaml.safe_load(out.read_text())
    raw["data"] = {k: v for k, v in {**raw["data"], "area0": 40.0, **data}.items() if v is not None}
    out.write_text(yaml.safe_dump(raw, sort_keys=False, allow_unicode=True))
    return fit(load_config(out), write=False).estimate["E"]


@pytest.mark.parametrize(("zeroed", "key", "value"), [(False, "initial_state", "ramp-from-zero"),
                                                      (True, "toe", "compensate")])
def test_a_loaded_first_sample_gets_the_remedy_its_strain_points_to(tmp_path, zeroed, key, value):
    """The Bluehill-like export (E = 2854 MPa) without its first 5 rows: its first sample carries 30 %
    of the peak force. Its strain counts from the unloaded length: init writes initial_state:
    ramp-from-zero; zeroed there (a preload): toe: compensate. A check line names the other remedy,
    nothing is marked EDIT, and fit on the config as written is nearer the truth than with the
    unloaded start (toe: none, what init wrote before) and than with the other remedy."""
    out = tmp_path / "run" / "config.yaml"
    result = init_config(_cropped(tmp_path, 5, zeroed), out)
    assert any(p.startswith("the first sample") and f"init wrote data.{key}: {value}" in p
               for p in result.problems), result.problems
    [edit] = [e for e in result.edits if e.key == f"data.{key}"]
    assert edit.action == "check" and edit.value == value
    assert ("toe: compensate" if key == "initial_state" else "ramp-from-zero") in edit.why
    text = out.read_text()
    assert f"  {key}: {value}   # the first sample carries load" in text and "EDIT: the first" not in text
    other = {"toe": "compensate", "initial_state": None} if key == "initial_state" else \
        {"toe": None, "initial_state": "ramp-from-zero"}
    e, e_none, e_other = (_fit_e(out), _fit_e(out, toe="none", initial_state=None), _fit_e(out, **other))
    assert abs(e - 2854.0) < abs(e_other - 2854.0) and abs(e - 2854.0) < abs(e_none - 2854.0) / 4, \
        (e, e_other, e_none)
    if not zeroed:
        assert abs(e - 2854.0) < 0.03 * 2854.0


def test_an_unloaded_first_sample_gets_no_remedy(tmp_path):
    whole = init_config(BLUEHILL, tmp_path / "whole" / "config.yaml")
    assert all(e.key not in ("data.toe", "data.initial_state") for e in whole.edits)
    assert "toe:" not in (tmp_path / "whole" / "config.yaml").read_text()
    assert "initial_state:" not in (tmp_path / "whole" / "config.yaml").read_text()
