"""Property-based tests (hypothesis) of the three readers of user input: the config loader, the batch
manifest reader and the CSV reader. Random valid and invalid documents: each is either read to the
same values as a reference parse (PyYAML, the csv module, numpy) or refused with one of the
package's errors (the CLI's ``error:`` line) — never another exception, never a hang (each call
runs under an alarm).

Fixed seed (``derandomize``) and a small budget in the default suite (a few seconds); ``-m slow``
runs the ``long`` profile. With ``-s`` a tally is printed: documents tried, refused, tracebacks,
hangs, CPU time.
"""

from __future__ import annotations

import csv
import io
import math
import signal
import time
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bayes_dnlr.config import ConfigError, parse_config
from bayes_dnlr.config.yamlio import YamlError, parse_yaml
from bayes_dnlr.data.errors import DataError
from bayes_dnlr.errors import BayesDnlrError

ALARM_S = 10
TALLY: Counter[str] = Counter()
CPU = {"t": 0.0}

settings.register_profile("default", max_examples=60, derandomize=True, deadline=None,
                          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
settings.register_profile("long", max_examples=2000, derandomize=True, deadline=None,
                          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
DEFAULT = settings.get_profile("default")
LONG = settings.get_profile("long")


class Hang(Exception):
    pass


def _alarm(signum, frame):
    raise Hang("no answer within the alarm")


def judged(kind: str, call):
    """Run ``call`` under an alarm; count it as read or refused (a package error); anything else
    (a traceback, a hang) fails the test."""
    TALLY[f"{kind} tried"] += 1
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(ALARM_S)
    t0 = time.process_time()
    try:
        result = call()
    except BayesDnlrError as err:
        assert str(err) and "\n" not in str(err), f"not one line: {err!r}"
        TALLY[f"{kind} refused"] += 1
        return None
    except Hang:
        TALLY["hangs"] += 1
        raise
    except Exception:
        TALLY["tracebacks"] += 1
        raise
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
        CPU["t"] += time.process_time() - t0
    TALLY[f"{kind} read"] += 1
    return result


@pytest.fixture(scope="module", autouse=True)
def tally():
    yield
    print("\ninput properties: " + ", ".join(f"{k} {v}" for k, v in sorted(TALLY.items()))
          + f"; tracebacks {TALLY['tracebacks']}, hangs {TALLY['hangs']}, CPU {CPU['t']:.2f} s")


# ---------------------------------------------------------------- YAML documents

scalars = st.one_of(st.none(), st.booleans(), st.integers(-10**6, 10**6),
                    st.floats(allow_nan=False, allow_infinity=False, width=32),
                    st.text(st.characters(codec="utf-8", exclude_categories=("Cs",)), max_size=12))
keys = st.text(st.characters(min_codepoint=97, max_codepoint=122), min_size=1, max_size=8)
documents = st.recursive(scalars, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                          st.dictionaries(keys, inner, max_size=4)),
                         max_leaves=25)

# fragments that hostile or careless documents are made of
HOSTILE = ["[", "]", "{", "}", "&a ", "*a", "!!python/object:os.system ", "\t", ": ", "- ", "---\n",
           "%YAML 1.1\n", "'", '"', "? ", "<<: *a\n", "\x00", "\ufeff", "1e12", "true", ".nan", "~", "#",
           "\n  ", "|\n", ">\n", "&b [*a, *a, *a]", "key: value\nkey: other\n"]


@st.composite
def mangled(draw) -> str:
    """A YAML text with hostile fragments spliced in at random places."""
    text = yaml.safe_dump(draw(documents))
    for _ in range(draw(st.integers(1, 6))):
        at = draw(st.integers(0, len(text)))
        text = text[:at] + draw(st.sampled_from(HOSTILE)) + text[at:]
    return text


def _without_exponent_floats(doc) -> bool:
    """PyYAML's reference (YAML 1.1) reads 1e5 as a string where the loader reads a number."""
    text = yaml.safe_dump(doc)
    return "e+" not in text and "e-" not in text


@given(documents)
@DEFAULT
def test_valid_yaml_reads_as_the_reference(doc) -> None:
    text = yaml.safe_dump(doc)
    got = judged("yaml", lambda: parse_yaml(text, "doc.yaml"))
    if _without_exponent_floats(doc):
        assert got == yaml.safe_load(text)


@given(mangled())
@DEFAULT
def test_hostile_yaml_read_or_refused(text: str) -> None:
    got = judged("yaml", lambda: parse_yaml(text, "doc.yaml"))
    if got is not None and "1e12" not in text:
        assert got == yaml.safe_load(text)     # what it reads, the reference reads alike


# ---------------------------------------------------------------- configs

BASE = {"name": "t", "data": {"file": "x.csv", "columns": {"time": "t", "force": "F", "eps11": "e"},
                              "area0": 24.0}}
PATHS = ["data.area0", "data.strain_rate", "data.window.strain_max", "data.rows.first", "model.modes",
         "model.decades", "sampler.walkers", "sampler.seed", "sampler.target_ess", "noise.sigma0",
         "parameters.E", "parameters.E.low", "parameters.tau_max.value", "fit.multistart", "name",
         "data.columns.time", "data.header", "truth", "tests", "output.dir", "unknown"]


@st.composite
def configs(draw) -> dict:
    raw = yaml.safe_load(yaml.safe_dump(BASE))
    values = st.one_of(documents, st.floats(1e-3, 1e4), st.integers(1, 200))
    for _ in range(draw(st.sampled_from([0, 0, 1, 1, 2, 4]))):
        *parents, last = draw(st.sampled_from(PATHS)).split(".")
        node = raw
        for k in parents:
            node = node.setdefault(k, {}) if isinstance(node.get(k, {}), dict) else {}
        node[last] = draw(values)
    return raw


@given(configs())
@DEFAULT
def test_config_validated_or_refused(raw: dict) -> None:
    text = yaml.safe_dump(raw)

    def load():
        return parse_config(parse_yaml(text, "config.yaml"), source=Path("/nowhere/config.yaml"))

    cfg = judged("config", load)
    if cfg is not None:            # what was read is what was written, after resolution
        assert cfg.name == raw["name"]
        area = (raw.get("data") or {}).get("area0")
        if cfg.data is not None and area is not None:
            assert not isinstance(area, bool) and math.isclose(cfg.data.area0, area)


def test_config_errors_are_config_errors() -> None:
    for bad in ("area0: true", "walkers: yes"):
        with pytest.raises((ConfigError, YamlError)):
            parse_config(parse_yaml(f"name: t\n{bad}\n", "c.yaml"))


# ---------------------------------------------------------------- manifests

cells = st.one_of(st.text(st.characters(codec="utf-8", exclude_categories=("Cs",)), max_size=10),
                  st.floats(allow_nan=False, width=32).map(str), st.sampled_from(
                      ["", "null", "true", "{prior: half-normal, scale: 5}", "[" * 40, "&a [*a]", '"']))
GOOD_COLUMNS = ["name", "data.file", "data.area0", "sampler.seed", "noise.sigma0", "data.window.strain_max"]
headers = st.one_of(
    st.lists(st.sampled_from(GOOD_COLUMNS), min_size=1, max_size=5, unique=True),
    st.lists(st.sampled_from([*GOOD_COLUMNS, "bad key", "", "data..x", "name"]), min_size=1, max_size=5))


@st.composite
def manifests(draw) -> str:
    header = draw(headers)
    rows = draw(st.lists(st.lists(cells, min_size=0, max_size=len(header) + 1), max_size=5))
    delim = draw(st.sampled_from([",", ";", "\t"]))
    buf = io.StringIO()
    w = csv.writer(buf, delimiter=delim)
    w.writerow(header)
    w.writerows(rows)
    return buf.getvalue()


@given(manifests())
@DEFAULT
def test_manifest_read_as_the_csv_module_or_refused(tmp_path_factory, text: str) -> None:
    from bayes_dnlr.workflows.batch.manifest import parse_cell, read_manifest

    path = tmp_path_factory.mktemp("m") / "manifest.csv"
    path.write_text(text, encoding="utf-8")
    got = judged("manifest", lambda: read_manifest(path))
    if got is not None:
        header, rows = got
        text = path.read_text(encoding="utf-8-sig")      # as the reader sees it (universal newlines)
        try:
            sniffed = csv.Sniffer().sniff(text[:4096], delimiters=",;\t")
        except csv.Error:
            sniffed = csv.excel
        ref = [r for r in csv.reader(text.splitlines(), sniffed) if any(c.strip() for c in r)]
        assert header == [h.strip() for h in ref[0]]
        assert [list(cells_.values()) for _, cells_ in rows] == [
            r + [""] * (len(header) - len(r)) for r in ref[1:]]
        for _, row in rows:
            for cell in row.values():
                judged("manifest cell", lambda c=cell: parse_cell(c))


# ---------------------------------------------------------------- CSV data files

numbers = st.floats(-1e6, 1e6, allow_nan=False, width=32)


@st.composite
def data_files(draw) -> tuple[str, np.ndarray | None]:
    """A CSV of three columns (t, F, e): valid (increasing time, numbers) with its values, or the same
    with damage spliced in (then None)."""
    n = draw(st.integers(3, 30))
    t = np.cumsum(np.array(draw(st.lists(st.floats(0.25, 10, width=32), min_size=n, max_size=n))))
    vals = np.column_stack([t, draw(st.lists(numbers, min_size=n, max_size=n)),
                            draw(st.lists(st.floats(0, 1, width=32), min_size=n, max_size=n))])
    lines = ["t,F,e"] + [",".join(repr(float(v)) for v in row) for row in vals]
    if draw(st.booleans()):
        return "\n".join(lines) + "\n", vals
    for _ in range(draw(st.integers(1, 4))):
        i = draw(st.integers(0, len(lines) - 1))
        junk = draw(st.sampled_from(["", ",", ";", "nan", "1e400", "x", "\x00", "\"", ",,,,", "1,2",
                                     "\ufeff", "ü", "1.2.3", "-", "inf", "0x10", " "]))
        at = draw(st.integers(0, len(lines[i])))
        lines[i] = lines[i][:at] + junk + lines[i][at:]
    return "\n".join(lines) + "\n", None


@given(data_files())
@DEFAULT
def test_csv_read_as_numpy_or_refused(tmp_path_factory, case) -> None:
    from bayes_dnlr.config import DataConfig
    from bayes_dnlr.data.reading import read_table

    text, values = case
    path = tmp_path_factory.mktemp("d") / "test.csv"
    path.write_text(text, encoding="utf-8")
    d = DataConfig.model_validate({"file": "test.csv", "columns": {"time": "t", "force": "F", "eps11": "e"},
                                   "area0": 24.0})
    table = judged("csv", lambda: read_table(path, d))
    if table is not None and values is not None:
        ref = np.loadtxt(io.StringIO(text), delimiter=",", skiprows=1, ndmin=2)
        np.testing.assert_allclose(table.values["time"], ref[:, 0], rtol=1e-12)
        np.testing.assert_allclose(table.values["force"], ref[:, 1], rtol=1e-12)


def test_refusals_are_data_errors(tmp_path: Path) -> None:
    from bayes_dnlr.config import DataConfig
    from bayes_dnlr.data.reading import read_table

    path = tmp_path / "test.csv"
    path.write_text("t,F,e\n1,2,x\n")
    d = DataConfig.model_validate({"file": "test.csv", "columns": {"time": "t", "force": "F", "eps11": "e"},
                                   "area0": 24.0})
    with pytest.raises(DataError):
        read_table(path, d)


# ---------------------------------------------------------------- the long profile

@pytest.mark.slow
@given(mangled())
@LONG
def test_hostile_yaml_long(text: str) -> None:
    judged("yaml", lambda: parse_yaml(text, "doc.yaml"))


@pytest.mark.slow
@given(configs())
@LONG
def test_config_long(raw: dict) -> None:
    text = yaml.safe_dump(raw)
    judged("config", lambda: parse_config(parse_yaml(text, "c.yaml"), source=Path("/nowhere/c.yaml")))


@pytest.mark.slow
@given(data_files())
@LONG
def test_csv_long(tmp_path_factory, case) -> None:
    test_csv_read_as_numpy_or_refused.hypothesis.inner_test(tmp_path_factory, case)


@pytest.mark.slow
@given(manifests())
@LONG
def test_manifest_long(tmp_path_factory, text: str) -> None:
    test_manifest_read_as_the_csv_module_or_refused.hypothesis.inner_test(tmp_path_factory, text)
