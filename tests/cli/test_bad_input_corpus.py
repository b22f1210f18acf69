"""The bad-input corpus: a generated set of broken or awkward configs, CSV files and run
environments, each run through the command line.

For every case the test asserts the outcome class:

- ``error``: exit 2 and exactly one line on stderr, ``error: ...``, that names the key, file, line
  or column to fix (the case's ``names``), and the run folder exactly as it was before (no lock, no
  temporary, no half-made output);
- ``accept``: exit 0 and the outputs of the command (for awkward but valid input), with the note the
  case expects when there is one;

and never a traceback. Error cases run through ``fit`` and ``sample`` (both must stop before any
work); accepted cases through ``fit`` only. In-process (``cli.main``) for speed, plus a few real
subprocesses to prove nothing reaches the terminal but the one line.
"""

from __future__ import annotations

import copy
import os
import re
import shutil
import subprocess
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from bayes_dnlr import cli
from bayes_dnlr.model.dnlr import simulate

# ---------------------------------------------------------------- the base case (valid)

AREA0 = 24.0
ROWS = 200                      # data rows; header at line 1, so data row i is at line i + 1
BASE_CFG: dict[str, Any] = {
    "name": "corpus",
    "data": {"file": "test.csv", "columns": {"time": "t_s", "force": "F_N", "eps11": "eps11"},
             "area0": AREA0, "window": {"strain_max": 0.2}},
    "parameters": {"E": {"prior": "uniform", "low": 100, "high": 20000},
                   "G": {"prior": "uniform", "low": 0, "high": 50},
                   "tau_max": {"prior": "log-uniform", "low": 0.01, "high": 10000}},
    "noise": {"sigma0": 0.3, "discrepancy": "none"},
    "sampler": {"walkers": 8, "max_steps": 30, "target_ess": 50, "seed": 1, "checkpoint_every": 10},
    "fit": {"multistart": 0},
    "output": {"dir": "run"},
}


def base_csv() -> str:
    """A synthetic tensile test (the paper's HDPE, eq. 18) at 5e-3 1/s to Hencky strain 0.2."""
    rng = np.random.default_rng(10)
    t = np.linspace(0.0, 40.0, ROWS)
    eps = 5e-3 * t
    stress = simulate(t, eps, {"E": 2854.0, "G": 2.32, "tau_max": 5.79})
    force = stress * AREA0 * np.exp(-eps) + rng.normal(0.0, 0.3 * AREA0, ROWS)   # sigma* = F/S0 e^eps
    force[0] = 0.0
    eps_meas = eps + rng.normal(0.0, 1e-5, ROWS)
    eps_meas[0] = 0.0
    rows = [f"{a:.6g},{b:.8g},{c:.6g}" for a, b, c in zip(t, eps_meas, force, strict=True)]
    return "t_s,eps11,F_N\n" + "\n".join(rows) + "\n"


BASE_CSV = base_csv()
BASE_YAML = yaml.safe_dump(BASE_CFG, sort_keys=False)


# ---------------------------------------------------------------- cases

@dataclass
class Case:
    id: str
    kind: str                                  # yaml | config | csv | environment
    expect: str                                # error | accept
    names: tuple[str, ...] = ()                # substrings the error line (or an accepted note) must hold
    cfg: Callable[[dict], Any] | None = None   # the config dict -> a dict (dumped) or raw text/bytes
    yaml_text: Callable[[str], str | bytes] | None = None   # the YAML text -> text or bytes
    csv: Callable[[str], str | bytes] | None = None
    setup: Callable[[Path], None] | None = None
    commands: tuple[str, ...] = ("fit", "sample")
    extra: list[str] = field(default_factory=list)
    note_in_fit: str | None = None             # accept: a text fit.json's notes must hold


DELETE = object()


def with_(path: str, value: Any) -> Callable[[dict], dict]:
    """The config with the dotted key ``path`` set to ``value`` (DELETE removes it)."""
    def edit(cfg: dict) -> dict:
        cfg = copy.deepcopy(cfg)
        node = cfg
        *parents, last = path.split(".")
        for k in parents:
            node = node.setdefault(k, {})
        if value is DELETE:
            node.pop(last, None)
        else:
            node[last] = value
        return cfg
    return edit


def lines_of(text: str) -> list[str]:
    return text.splitlines()


def set_cell(line: int, column: int, value: str) -> Callable[[str], str]:
    """The CSV with file line ``line`` (from 1), column ``column`` (from 0) replaced."""
    def edit(text: str) -> str:
        rows = lines_of(text)
        cells = rows[line - 1].split(",")
        cells[column] = value
        rows[line - 1] = ",".join(cells)
        return "\n".join(rows) + "\n"
    return edit


def set_line(line: int, value: str) -> Callable[[str], str]:
    def edit(text: str) -> str:
        rows = lines_of(text)
        rows[line - 1] = value
        return "\n".join(rows) + "\n"
    return edit


def map_column(column: int, f: Callable[[float], float]) -> Callable[[str], str]:
    def edit(text: str) -> str:
        rows = lines_of(text)
        out = [rows[0]]
        for r in rows[1:]:
            cells = r.split(",")
            cells[column] = f"{f(float(cells[column])):.8g}"
            out.append(",".join(cells))
        return "\n".join(out) + "\n"
    return edit


T, EPS, F = 0, 1, 2            # CSV columns
L = 51                         # a data line in the loading ramp


def _yaml_cases() -> list[Case]:
    top = BASE_YAML
    cases = [
        Case("yaml-unclosed-bracket", "yaml", "error", ("config.yaml", "line", "not valid YAML"),
             yaml_text=lambda s: s.replace("name: corpus", "name: [corpus")),
        Case("yaml-tab-indent", "yaml", "error", ("config.yaml", "line", "not valid YAML"),
             yaml_text=lambda s: s.replace("  area0:", "\tarea0:")),
        Case("yaml-bad-indent", "yaml", "error", ("config.yaml", "line"),
             yaml_text=lambda s: s.replace("  area0:", "   area0:")),
        Case("yaml-unclosed-quote", "yaml", "error", ("config.yaml", "line", "not valid YAML"),
             yaml_text=lambda s: s.replace("name: corpus", "name: 'corpus")),
        Case("yaml-two-documents", "yaml", "error", ("config.yaml", "not valid YAML"),
             yaml_text=lambda s: s + "---\nname: other\n"),
        Case("yaml-not-utf8", "yaml", "error", ("config.yaml", "line 1", "UTF-8"),
             yaml_text=lambda s: ("# r\xe9sum\xe9\n" + s).encode("latin-1")),
        Case("yaml-binary", "yaml", "error", ("config.yaml", "UTF-8"),
             yaml_text=lambda s: bytes(range(128, 256)) * 4),
        Case("yaml-utf16", "yaml", "error", ("config.yaml",),
             yaml_text=lambda s: s.encode("utf-16")),
        Case("yaml-empty", "yaml", "error", ("config.yaml", "mapping"), yaml_text=lambda s: ""),
        Case("yaml-list", "yaml", "error", ("config.yaml", "mapping"), yaml_text=lambda s: "- a\n- b\n"),
        Case("yaml-scalar", "yaml", "error", ("config.yaml", "mapping"), yaml_text=lambda s: "hello\n"),
        Case("yaml-python-tag", "yaml", "error", ("config.yaml", "not valid YAML"),
             yaml_text=lambda s: s.replace("name: corpus", "name: !!python/object:os.system corpus")),
        # duplicate keys: the last would silently win
        Case("dup-top-level", "yaml", "error", ("key 'name' is given twice", "line"),
             yaml_text=lambda s: s + "name: other\n"),
        Case("dup-nested-area0", "yaml", "error", ("key 'data.area0' is given twice", "line"),
             yaml_text=lambda s: s.replace("  area0: 24.0\n", "  area0: 24.0\n  area0: 30.0\n")),
        Case("dup-flow-mapping", "yaml", "error", ("key 'noise.sigma0' is given twice",),
             yaml_text=lambda s: s.replace("noise:\n  sigma0: 0.3\n  discrepancy: none\n",
                                          "noise: {sigma0: 0.3, discrepancy: none, sigma0: 3}\n")),
        Case("dup-section", "yaml", "error", ("key 'sampler' is given twice",),
             yaml_text=lambda s: s + "sampler: {walkers: 64}\n"),
        Case("dup-deep-prior", "yaml", "error", ("key 'parameters.E.high' is given twice",),
             yaml_text=lambda s: s.replace("    high: 20000\n", "    high: 20000\n    high: 30000\n", 1)),
        Case("dup-in-a-list", "yaml", "error", ("key 'tests[1].data' is given twice",),
             yaml_text=lambda s: s.replace("data:\n", "tests:\n- {name: a, data: {file: test.csv}}\n"
                                           "- {name: b, data: {file: test.csv}, data: {file: x.csv}}\n"
                                           "old_data:\n", 1)),
        # hostile YAML: refused in bounded time and memory (config/yamlio.py limits)
        Case("yaml-alias-bomb", "yaml", "error", ("config.yaml", "aliases expand"),
             yaml_text=lambda s: s + "".join(
                 f"x{i}: &a{i} [" + ", ".join([f"*a{i - 1}" if i else "l"] * 9) + "]\n" for i in range(9))),
        Case("yaml-recursive-alias", "yaml", "error", ("config.yaml", "alias refers"),
             yaml_text=lambda s: s + "loop: &l [1, *l]\n"),
        Case("yaml-deep-nesting", "yaml", "error", ("config.yaml", "line", "nested deeper"),
             yaml_text=lambda s: s + "deep: " + "[" * 5000 + "]" * 5000 + "\n"),
        Case("yaml-too-large", "yaml", "error", ("config.yaml", "bytes"),
             yaml_text=lambda s: s + "# " + "x" * (1 << 20) + "\n"),
        # awkward but valid YAML
        Case("yaml-bom", "yaml", "accept", yaml_text=lambda s: "\ufeff" + s, commands=("fit",)),
        Case("yaml-crlf", "yaml", "accept", yaml_text=lambda s: s.replace("\n", "\r\n"), commands=("fit",)),
        Case("yaml-walkers-1e12", "yaml", "error", ("sampler.walkers", "memory"),
             yaml_text=lambda s: s.replace("walkers: 8", "walkers: 1e12")),
        Case("yaml-sigma0-exponent", "yaml", "accept", commands=("fit",),
             yaml_text=lambda s: s.replace("sigma0: 0.3", "sigma0: 3e-1")),
        Case("yaml-comments-anchors", "yaml", "accept", commands=("fit",),
             yaml_text=lambda s: "# a comment\n" + s.replace("name: corpus", "name: &n corpus  # run")),
    ]
    assert top
    return cases


# (key, value, names the error must hold): each a config that must be refused before any work
CONFIG_ERRORS: list[tuple[str, Any, tuple[str, ...]]] = [
    ("data.area0", float("nan"), ("data.area0", "finite")),
    ("data.area0", float("inf"), ("data.area0", "finite")),
    ("data.area0", 0.0, ("data.area0",)),
    ("data.area0", -24.0, ("data.area0",)),
    ("data.area0", "big", ("data.area0",)),
    ("data.area0", True, ("data.area0", "expected a number", "boolean")),
    ("data.area0", "24", ("data.area0", "expected a number")),
    ("model.modes", True, ("model.modes", "whole number", "boolean")),
    ("data.area0", DELETE, ("area0",)),
    ("data.window.strain_max", float("nan"), ("data.window.strain_max", "finite")),
    ("data.window.strain_max", float("inf"), ("data.window.strain_max", "finite")),
    ("data.window.strain_min", 0.3, ("strain_min", "strain_max")),
    ("data.window.time_max", -5.0, ("data.window",)),
    ("data.window.strain_max", 50.0, ("data.window",)),
    ("data.window.foo", 1, ("data.window.foo", "unknown key")),
    ("data.strain_rate", -1.0, ("data.strain_rate",)),
    ("data.columns.force", "Force", ("'Force'",)),
    ("data.columns.eps11", DELETE, ("data.columns",)),
    ("data.columns.time", 9, ("data.columns",)),
    ("data.observable", "strain", ("data.observable",)),
    ("data.encoding", "klingon", ("data.encoding",)),
    ("data.file", "missing.csv", ("missing.csv", "not found")),
    ("parameters.E.low", float("nan"), ("parameters.E.low", "finite")),
    ("parameters.E.high", float("inf"), ("parameters.E.high", "finite")),
    ("parameters.E.high", 1e308, ("parameters.E.high",)),
    ("parameters.E.low", -1e308, ("parameters.E.low",)),
    ("parameters.E.low", 30000, ("parameters.E", "low", "high")),
    ("parameters.tau_max.high", 1e308, ("parameters.tau_max.high",)),
    ("parameters.tau_max", {"value": float("nan")}, ("parameters.tau_max.value", "finite")),
    ("parameters.tau_max", {"value": -1.0}, ("parameters.tau_max.value", "> 0")),
    ("parameters.tau_max", {"value": 0.0}, ("parameters.tau_max.value", "> 0")),
    ("parameters.tau_max", {"prior": "uniform", "low": -5, "high": 10}, ("parameters.tau_max",)),
    ("parameters.tau_max", {"prior": "normal", "mean": 5, "sd": 1}, ("parameters.tau_max",)),
    ("parameters.G", {"value": float("inf")}, ("parameters.G.value", "finite")),
    ("parameters.G", {"value": 1e308}, ("parameters.G.value",)),
    ("parameters.E", {"value": -2000.0}, ("parameters.E.value",)),
    ("parameters.E", {"prior": "normal", "mean": 3000}, ("parameters.E", "sd")),
    ("parameters.E", {"prior": "cauchy", "low": 1, "high": 2}, ("parameters.E.prior",)),
    ("parameters.nu", {"value": 0.4}, ("parameters", "nu")),
    ("parameters.sigma_inf", {"value": 5.0}, ("relaxation",)),
    ("noise.sigma0", float("nan"), ("noise.sigma0",)),
    ("noise.sigma0", float("inf"), ("noise.sigma0",)),
    ("noise.sigma0", 0.0, ("noise.sigma0",)),
    ("noise.sigma0", -0.3, ("noise.sigma0",)),
    ("noise.sigma0", 1e308, ("noise.sigma0",)),
    ("noise.sigma0", "auto", ("noise.sigma0",)),
    ("noise.sigma0", {"prior": "half-normal", "scale": float("nan")}, ("noise.sigma0.scale", "finite")),
    ("noise.sigma0", {"prior": "uniform", "low": -1.0, "high": 1.0}, ("noise.sigma0.low",)),
    ("noise.sigma0", {"prior": "log-uniform", "low": 0.1}, ("noise.sigma0", "high")),
    ("noise.discrepancy", "gp", ("noise.discrepancy",)),
    ("noise.discrepancy", {"kernel": "rbf"}, ("noise.discrepancy.kernel",)),
    ("sampler.seed", -1, ("sampler.seed", "0")),
    ("sampler.seed", 2**32, ("sampler.seed", "4294967296")),
    ("sampler.seed", 1.5, ("sampler.seed",)),
    ("sampler.seed", "abc", ("sampler.seed",)),
    ("sampler.walkers", "twelve", ("sampler.walkers", "whole number")),
    ("sampler.walkers", 32.5, ("sampler.walkers", "whole number")),
    ("sampler.walkers", 10**12, ("sampler.walkers", "memory")),
    ("sampler.walkers", 0, ("sampler.walkers",)),
    ("sampler.walkers", 4, ("sampler.walkers",)),
    ("sampler.walkers", -32, ("sampler.walkers",)),
    ("sampler.max_steps", 0, ("sampler.max_steps",)),
    ("sampler.max_steps", 10**15, ("sampler.max_steps", "memory")),
    ("sampler.target_ess", float("inf"), ("sampler.target_ess", "finite")),
    ("sampler.target_ess", float("nan"), ("sampler.target_ess", "finite")),
    ("sampler.target_ess", -1, ("sampler.target_ess",)),
    ("sampler.checkpoint_every", 0, ("sampler.checkpoint_every",)),
    ("sampler.moves", "gibbs", ("sampler.moves",)),
    ("sampler.burn_in_tau", float("nan"), ("sampler.burn_in_tau", "finite")),
    ("model.modes", 0, ("model.modes",)),
    ("model.modes", 10**6, ("model.modes",)),
    ("model.decades", float("nan"), ("model.decades", "finite")),
    ("model.decades", -6, ("model.decades",)),
    ("fit.multistart", -1, ("fit.multistart",)),
    ("fit.method", "newton", ("fit.method",)),
    ("fit.max_iterations", 0, ("fit.max_iterations",)),
    ("name", "bad/name", ("name",)),
    ("name", "", ("name",)),
    ("name", DELETE, ("name", "missing")),
    ("data", DELETE, ("data:",)),
    ("walkers", 32, ("walkers", "unknown key")),
]


def _config_cases() -> list[Case]:
    cases = []
    for key, value, names in CONFIG_ERRORS:
        text = "del" if value is DELETE else (str(value) if not isinstance(value, dict) else
                                               "-".join(f"{k}={v}" for k, v in value.items()))
        cases.append(Case(f"cfg-{key}={text}", "config", "error", names, cfg=with_(key, value)))
    cases += [
        Case("cfg-tests-and-data", "config", "error", ("data:", "tests:"),
             cfg=with_("tests", [{"name": "a", "data": BASE_CFG["data"]}])),
        Case("cfg-tests-duplicate-name", "config", "error", ("tests[1].name",),
             cfg=lambda c: {**with_("data", DELETE)(c), "tests": [
                 {"name": "a", "data": c["data"]}, {"name": "a", "data": c["data"]}]}),
        # awkward but valid
        Case("cfg-scientific-sigma0", "config", "accept", cfg=with_("noise.sigma0", "3e-1"),
             commands=("fit",)),
        Case("cfg-int-area0", "config", "accept", cfg=with_("data.area0", 24), commands=("fit",)),
        Case("cfg-seed-max", "config", "accept", cfg=with_("sampler.seed", 2**32 - 1), commands=("fit",)),
        Case("cfg-tau-uniform-from-0", "config", "accept", commands=("fit",),
             cfg=with_("parameters.tau_max", {"prior": "uniform", "low": 0, "high": 100})),
        Case("cfg-tau-high-1e12", "config", "accept", commands=("fit",),
             cfg=with_("parameters.tau_max.high", 1e12)),
    ]
    return cases


# (id, edit, names): CSV files that must be refused with the file, line and column
CSV_ERRORS: list[tuple[str, Callable[[str], str | bytes], tuple[str, ...]]] = [
    ("force-1e300", set_cell(L, F, "1e300"), ("test.csv", f"line {L}", "F_N")),
    ("force-1e308", set_cell(L, F, "1e308"), ("test.csv", f"line {L}", "F_N")),
    ("force-text", set_cell(L, F, "abc"), ("test.csv", f"line {L}", "F_N")),
    ("force-underscore", set_cell(L, F, "6_54.93"), ("test.csv", f"line {L}", "underscore")),
    ("force-fullwidth", set_cell(L, F, "\uff15\uff10"), ("test.csv", f"line {L}", "ASCII")),
    ("force-nan", set_cell(L, F, "nan"), ("test.csv", f"line {L}", "F_N")),
    ("force-inf", set_cell(L, F, "inf"), ("test.csv", f"line {L}", "F_N")),
    ("force-double-minus", set_cell(L, F, "--5"), ("test.csv", f"line {L}", "F_N")),
    ("force-two-points", set_cell(L, F, "1.2.3"), ("test.csv", f"line {L}", "F_N")),
    ("strain-text", set_cell(L, EPS, "x"), ("test.csv", f"line {L}", "eps11")),
    ("strain-huge", set_cell(L, EPS, "1e6"), ("test.csv", f"line {L}", "eps11")),
    ("time-text", set_cell(L, T, "noon"), ("test.csv", f"line {L}", "t_s")),
    ("time-repeated", set_cell(L, T, lines_of(BASE_CSV)[L - 2].split(",")[0]), ("test.csv", "t_s")),
    ("time-backwards", set_cell(L, T, "0.5"), ("test.csv", "t_s")),
    ("short-row", set_line(L, "1.0,0.001"), ("test.csv", f"line {L}")),
    ("long-row", set_line(L, lines_of(BASE_CSV)[L - 1] + ",7,8"), ("test.csv", f"line {L}")),
    ("header-missing-force", set_line(1, "t_s,eps11,Force"), ("'F_N'",)),
    ("header-only", lambda s: "t_s,eps11,F_N\n", ("test.csv",)),
    ("empty-file", lambda s: "", ("test.csv",)),
    ("blank-file", lambda s: "\n\n\n", ("test.csv",)),
    ("binary-garbage", lambda s: bytes(range(256)) * 20, ("test.csv",)),
    ("three-rows", lambda s: "\n".join(lines_of(s)[:4]) + "\n", ("test.csv",)),
    ("force-all-zero", map_column(F, lambda v: 0.0), ("test.csv", "no tensile load", "F_N")),
    ("force-negated", map_column(F, lambda v: -v), ("test.csv", "no tensile load", "negate")),
    ("time-all-zero", map_column(T, lambda v: 0.0), ("test.csv", "t_s")),
    ("strain-constant", map_column(EPS, lambda v: 0.01), ("test.csv",)),
    ("html-page", lambda s: "<html><body>404 Not Found</body></html>\n", ("test.csv",)),
    ("quote-never-closed", lambda s: s.rstrip("\n").rpartition("\n")[0] + '\n"' + s.rstrip("\n")
     .rpartition("\n")[2] + "\n", ("test.csv", f"line {ROWS + 1}", "quote")),
]

# awkward CSV files that are valid, with the note the data layer must give (None: none asked)
CSV_ACCEPTS: list[tuple[str, Callable[[str], str | bytes], str | None]] = [
    ("crlf", lambda s: s.replace("\n", "\r\n"), None),
    ("utf8-bom", lambda s: "\ufeff" + s, None),
    ("trailing-blank-lines", lambda s: s + "\n\n", None),
    ("semicolon-decimal-comma", lambda s: s.replace(",", ";").replace(".", ","), "delimiter ';'"),
    ("tab-delimited", lambda s: s.replace(",", "\t"), None),
    ("force-spike-x1000", set_cell(L, F, "654000"), f"spike at line {L}"),
    ("quoted-cells", lambda s: "\n".join(",".join(f'"{c}"' for c in r.split(","))
                                         for r in lines_of(s)) + "\n", None),
]


def _csv_cases() -> list[Case]:
    cases = [Case(f"csv-{i}", "csv", "error", names, csv=edit) for i, edit, names in CSV_ERRORS]
    cases += [Case(f"csv-accept-{i}", "csv", "accept", csv=edit, commands=("fit",), note_in_fit=note)
              for i, edit, note in CSV_ACCEPTS]
    return cases


# ---------------------------------------------------------------- environment

def _data_is_dir(d: Path) -> None:
    (d / "test.csv").unlink()
    (d / "test.csv").mkdir()


def _config_is_dir(d: Path) -> None:
    (d / "config.yaml").unlink()
    (d / "config.yaml").mkdir()


def _run_is_file(d: Path) -> None:
    (d / "run").write_text("not a folder\n")


def _run_under_file(d: Path) -> None:
    (d / "blocker").write_text("a file\n")


def _data_is_empty_symlink(d: Path) -> None:
    (d / "test.csv").unlink()
    (d / "test.csv").symlink_to(d / "nowhere.csv")


def _environment_cases() -> list[Case]:
    return [
        Case("env-config-missing", "environment", "error", ("config.yaml", "not found"),
             setup=lambda d: (d / "config.yaml").unlink()),
        Case("env-config-is-dir", "environment", "error", ("config.yaml", "directory"), setup=_config_is_dir),
        Case("env-data-is-dir", "environment", "error", ("test.csv", "directory"), setup=_data_is_dir),
        Case("env-data-missing", "environment", "error", ("test.csv", "not found"),
             setup=lambda d: (d / "test.csv").unlink()),
        Case("env-data-dangling-link", "environment", "error", ("test.csv",), setup=_data_is_empty_symlink),
        Case("env-run-dir-is-file", "environment", "error", ("run", "is a file", "output.dir"),
             setup=_run_is_file),
        Case("env-run-dir-under-file", "environment", "error", ("blocker", "file"),
             setup=_run_under_file, cfg=with_("output.dir", "blocker/run")),
    ]


CASES = _yaml_cases() + _config_cases() + _csv_cases() + _environment_cases()


# ---------------------------------------------------------------- running a case

def listing(folder: Path) -> dict[str, tuple[int, int]]:
    """Every path under ``folder``, with size and mtime for files (what a failed command must not
    touch; a folder's own mtime changes when a lock file comes and goes, so only its presence counts)."""
    out = {}
    for p in sorted(folder.rglob("*")):
        st = p.lstat()
        out[str(p.relative_to(folder))] = (st.st_size, st.st_mtime_ns) if p.is_file() else (-1, 0)
    return out


def make_case(folder: Path, case: Case) -> Path:
    """Write the case's config and CSV into ``folder``; the config's path."""
    folder.mkdir(parents=True, exist_ok=True)
    cfg: Any = BASE_CFG
    if case.cfg is not None:
        cfg = case.cfg(cfg)
    text: str | bytes = cfg if isinstance(cfg, str | bytes) else yaml.safe_dump(cfg, sort_keys=False)
    if case.yaml_text is not None:
        text = case.yaml_text(text if isinstance(text, str) else text.decode())
    config = folder / "config.yaml"
    config.write_bytes(text.encode() if isinstance(text, str) else text)
    csv = BASE_CSV if case.csv is None else case.csv(BASE_CSV)
    (folder / "test.csv").write_bytes(csv.encode() if isinstance(csv, str) else csv)
    if case.setup is not None:
        case.setup(folder)
    return config


def run_cli(args: list[str], capsys) -> tuple[int, str, str]:
    try:
        code = cli.main(args)
    except SystemExit as exit_:          # argparse
        code = exit_.code
    out, err = capsys.readouterr()
    return int(code or 0), out, err


def check_error(case: Case, command: str, code: int, out: str, err: str) -> None:
    where = f"{case.id} ({command})"
    assert "Traceback" not in out + err, f"{where}: traceback\n{err}"
    assert code == 2, f"{where}: exit {code}, expected 2\n{err}"
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), f"{where}: not one error line:\n{err}"
    for name in case.names:
        assert name in lines[0], f"{where}: the error does not name {name!r}:\n{lines[0]}"


@pytest.mark.parametrize("case", [c for c in CASES], ids=lambda c: c.id)
def test_corpus_case(tmp_path: Path, capsys, case: Case) -> None:
    config = make_case(tmp_path / "case", case)
    folder = config.parent
    for command in case.commands:
        before = listing(folder)
        code, out, err = run_cli([command, "--quiet", str(config), *case.extra], capsys)
        if case.expect == "error":
            check_error(case, command, code, out, err)
            assert listing(folder) == before, f"{case.id} ({command}): files changed"
        else:
            assert "Traceback" not in out + err, f"{case.id}: traceback\n{err}"
            assert code == 0, f"{case.id} ({command}): exit {code}\n{err}"
            made = sorted(set(listing(folder)) - set(before))
            # and the smoothed strain kept for the next commands (data/smoothing.py)
            cache = [m for m in made if m.startswith("run/.cache")]
            assert [m for m in made if m not in cache] == ["run", "run/config.yaml", "run/fit.json"], made
            assert all(re.fullmatch(r"run/\.cache(/strain-[0-9a-f]{32}\.npz)?", m) for m in cache), made
            if case.note_in_fit:
                assert case.note_in_fit in (folder / "run/fit.json").read_text(), case.id


# ---------------------------------------------------------------- environment around a finished run

@pytest.fixture(scope="module")
def finished_run(tmp_path_factory) -> Path:
    """A case folder with a finished run (fit and a 30-step chain) in ``run/``."""
    folder = tmp_path_factory.mktemp("finished") / "case"
    config = make_case(folder, Case("base", "environment", "accept"))
    for command in ("fit", "sample"):
        assert cli.main([command, "--quiet", str(config)]) == 0
    assert (folder / "run" / "summary.json").is_file()
    return folder


@contextmanager
def read_only(folder: Path) -> Iterator[None]:
    """``folder`` read-only for this process: a read-only bind mount as root (who ignores
    permissions), the write bits removed otherwise; skipped where neither works."""
    if os.geteuid() != 0:
        modes = {p: p.stat().st_mode for p in [folder, *folder.rglob("*")]}
        for p, m in modes.items():
            p.chmod(m & ~0o222)
        try:
            yield
        finally:
            for p, m in modes.items():
                p.chmod(m)
        return
    bind = subprocess.run(["mount", "--bind", str(folder), str(folder)], capture_output=True, text=True)
    if bind.returncode != 0:
        pytest.skip(f"cannot bind-mount a read-only folder: {bind.stderr.strip()}")
    try:
        ro = subprocess.run(["mount", "-o", "remount,bind,ro", str(folder)], capture_output=True, text=True)
        if ro.returncode != 0:
            pytest.skip(f"cannot remount read-only: {ro.stderr.strip()}")
        yield
    finally:
        if subprocess.run(["umount", str(folder)], capture_output=True).returncode != 0:
            subprocess.run(["umount", "-l", str(folder)], capture_output=True)


def _edit_config(folder: Path, edit: Callable[[dict], dict]) -> None:
    config = folder / "config.yaml"
    config.write_text(yaml.safe_dump(edit(yaml.safe_load(config.read_text())), sort_keys=False))


def _garbage(path: Path) -> None:
    path.write_bytes(b"\x00garbage\xff" * 64)


@dataclass
class RunCase:
    id: str
    command: str
    expect: str
    names: tuple[str, ...] = ()
    prepare: Callable[[Path], None] | None = None
    readonly: bool = False
    remove_run: bool = False


RUN_CASES = [
    RunCase("ro-finished-sample", "sample", "accept", ("finished earlier",), readonly=True),
    RunCase("ro-fit", "fit", "error", ("cannot write", "run", "read-only"), readonly=True),
    RunCase("ro-fresh-sample", "sample", "error", ("cannot write", "run", "Read-only"), readonly=True,
            remove_run=True),
    RunCase("ro-continue-sample", "sample", "error", ("cannot write", "Read-only"), readonly=True,
            prepare=lambda d: _edit_config(d, with_("sampler.max_steps", 60))),
    RunCase("ro-fresh-fit", "fit", "error", ("cannot write", "run"), readonly=True, remove_run=True),
    RunCase("stale-fit", "fit", "error", ("fit.json", "--force", "parameters"),
            prepare=lambda d: _edit_config(d, with_("parameters.E.high", 30000))),
    RunCase("stale-chain", "sample", "error", ("chains.h5", "another config", "--restart"),
            prepare=lambda d: _edit_config(d, with_("parameters.E.high", 30000))),
    RunCase("changed-seed", "sample", "error", ("chains.h5", "sampler", "--restart"),
            prepare=lambda d: _edit_config(d, with_("sampler.seed", 2))),
    RunCase("changed-fit-method-resume", "sample", "error", ("fit.json", "fit --force"),
            prepare=lambda d: _edit_config(d, lambda c: with_("fit.method", "gauss-newton")(
                with_("sampler.max_steps", 60)(c)))),
    RunCase("corrupt-chain", "sample", "error", ("chains.h5", "--restart"),
            prepare=lambda d: _garbage(d / "run" / "chains.h5")),
    RunCase("corrupt-fit-json", "fit", "error", ("fit.json", "--force"),
            prepare=lambda d: _garbage(d / "run" / "fit.json")),
    RunCase("data-changed", "sample", "error", ("chains.h5", "data file changed"),
            prepare=lambda d: (d / "test.csv").write_text(set_cell(L, F, "655.5")(BASE_CSV))),
    RunCase("data-removed", "sample", "error", ("test.csv", "not found"),
            prepare=lambda d: (d / "test.csv").unlink()),
    RunCase("finished-sample-again", "sample", "accept", ("finished earlier",)),
]


@pytest.mark.parametrize("case", RUN_CASES, ids=lambda c: c.id)
def test_corpus_run_environment(tmp_path: Path, capsys, finished_run: Path, case: RunCase) -> None:
    folder = tmp_path / "case"
    shutil.copytree(finished_run, folder, symlinks=True)
    if case.remove_run:
        shutil.rmtree(folder / "run")
    if case.prepare is not None:
        case.prepare(folder)
    config = folder / "config.yaml"
    with read_only(folder) if case.readonly else nullcontext():
        before = listing(folder)
        code, out, err = run_cli([case.command, "--quiet", str(config)], capsys)
        after = listing(folder)
    assert "Traceback" not in out + err, err
    if case.expect == "error":
        check_error(Case(case.id, "environment", "error", case.names), case.command, code, out, err)
    else:
        assert code == 0, err
        assert all(n in out + err for n in case.names), out + err
    assert after == before, f"{case.id}: files changed"


def test_locked_run_is_refused_and_the_lock_kept(tmp_path: Path, capsys, finished_run: Path) -> None:
    """A second `sample` on a run directory another one holds: one line, and the holder's lock
    (file and flock) untouched."""
    from bayes_dnlr.runs.lock import run_lock

    folder = tmp_path / "case"
    shutil.copytree(finished_run, folder)
    with run_lock(folder / "run", "sample.lock", "held by the test"):
        before = listing(folder)
        code, out, err = run_cli(["sample", "--quiet", str(folder / "config.yaml")], capsys)
        assert listing(folder) == before
    check_error(Case("locked", "environment", "error", ("another `sample` is running", "run")),
                "sample", code, out, err)
    assert not (folder / "run" / "sample.lock").exists()      # the holder removed it on release


@pytest.mark.parametrize("name", ["config.yaml", "test.csv"])
def test_unreadable_file(tmp_path: Path, capsys, monkeypatch, name: str) -> None:
    """A file the user may not read (permission denied; simulated, since root reads anything)."""
    import errno

    config = make_case(tmp_path / "case", Case("base", "environment", "accept"))
    real = Path.read_bytes

    def read_bytes(self: Path) -> bytes:
        if self.name == name:
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(self))
        return real(self)

    monkeypatch.setattr(Path, "read_bytes", read_bytes)
    for command in ("fit", "sample"):
        before = listing(config.parent)
        code, out, err = run_cli([command, "--quiet", str(config)], capsys)
        check_error(Case(f"unreadable-{name}", "environment", "error", (name, "ermission denied")),
                    command, code, out, err)
        assert listing(config.parent) == before


# ---------------------------------------------------------------- the real terminal

SUBPROCESS_CASES = ["dup-nested-area0", "cfg-parameters.tau_max=value=-1.0", "csv-strain-huge",
                    "csv-force-all-zero"]


@pytest.mark.parametrize("case_id", SUBPROCESS_CASES)
def test_nothing_but_the_line_reaches_the_terminal(tmp_path: Path, case_id: str) -> None:
    """A real process: stderr is the one error line (no traceback, no numpy warning), exit 2."""
    case = next(c for c in CASES if c.id == case_id)
    config = make_case(tmp_path / "case", case)
    before = listing(config.parent)
    proc = subprocess.run([sys.executable, "-m", "bayes_dnlr", "fit", str(config)],
                          capture_output=True, text=True, timeout=300)
    check_error(case, "fit (subprocess)", proc.returncode, proc.stdout, proc.stderr)
    assert proc.stdout == ""
    assert listing(config.parent) == before


def test_corpus_size_and_classes() -> None:
    """At least 100 cases, every class present, ids unique."""
    total = len(CASES) + len(RUN_CASES) + 1 + 2       # + the locked run, the unreadable files
    assert total >= 100
    assert len({c.id for c in CASES}) == len(CASES)
    kinds = {k: sum(c.kind == k for c in CASES) for k in ("yaml", "config", "csv", "environment")}
    kinds["environment"] += len(RUN_CASES) + 1 + 2
    assert all(n >= 10 for n in kinds.values()), kinds
    assert sum(c.expect == "accept" for c in CASES) >= 10
