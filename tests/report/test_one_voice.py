"""One voice: every number a message quotes is a number the run stores, of the estimate the message
names.

Six small runs (white noise, the model discrepancy, two tests jointly, the spectrum's exponent
sampled, a ramp then a hold, loading-unloading cycles) go through `fit`, `sample` and `report` on the
command line; every console line and every line of the page is cut into clauses, and each quoted
value is checked against fit.json and summary.json, whatever message quotes it (a message added
later is checked the same way):

- a parameter's value (``E = 2869``, ``tau_max[r0.01] = 4.02``, ``σ∞ = 19.9``) must name its
  estimate in its clause (posterior, white least squares, under model error / GLS, true, a bound,
  fixed) and equal, to the digits printed, that estimate as stored;
- De_max the same, against fit.json's (least squares) or the posterior's;
- an rms (``rms 0.28 MPa``, ``the rms of the whitened residuals (9.4, no unit)``) one of the stored
  rms values of its kind, whitened or not.

- a ratio of two sd (``2.01x the white one``; ``against the white one: E 2.03x, G 10.19x``) is
  written the number then ``x`` and names what it divides by; against the white one, it is the
  stored ratio of the estimate its clause names (the posterior's or the one under model error).

The word "verdict" names the checks' verdict only, a verdict leads with its decision and then the
checks that fail, a joint run's verdict never says "this test", the kernels' weights are never said
without what they weigh, the exponent's pull is said in sd, and the prior sensitivity of the run
with the exponent sampled is that of arviz_stats.psense on the priors as the config gives them.
"""

from __future__ import annotations

import contextlib
import html
import io
import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from support.drawing import figures_not_drawn

from bayes_dnlr.vocabulary import PARAMETER_NAMES, base_name

HDPE = {"E": 2854.0, "G": 2.32, "tau_max": 5.79}
SAMPLER = {"walkers": 16, "max_steps": 200, "target_ess": 60, "seed": 1, "checkpoint_every": 100}
PRIORS = {"E": {"prior": "uniform", "low": 100, "high": 20000},
          "G": {"prior": "uniform", "low": 0, "high": 50},
          "tau_max": {"prior": "log-uniform", "low": 0.01, "high": 10000}}
ALPHA = {"prior": "normal", "mean": 0.5, "sd": 0.05, "low": 0.0, "high": 1.0}


def _data(name: str, **keys: Any) -> dict:
    return {"file": f"{name}.csv", "columns": {"time": "t_s", "strain": "eps", "stress": "s"},
            "observable": "stress", **keys}


def _truth(**keys: Any) -> dict:
    t = {"params": HDPE, "strain_rate": 5e-3, "strain_max": 0.5, "n_points": 150,
         "noise": {"strain_sd": 0.0, "stress_sd": 0.3}, "seed": 1}
    t.update(keys)
    return t


RUNS: dict[str, dict] = {
    "white": {"data": _data("white"), "noise": {"sigma0": 0.3, "discrepancy": "none"}, "truth": _truth()},
    "discrepancy": {"data": _data("discrepancy"), "noise": {"sigma0": "residuals"},
                    "truth": _truth(noise={"strain_sd": 0.0, "stress_sd": 0.05},
                                    model_form={"kind": "two-process", "strength": "strong"})},
    "alpha": {"data": _data("alpha"), "noise": {"sigma0": 0.3, "discrepancy": "none"}, "truth": _truth(),
              "parameters": {**PRIORS, "alpha": ALPHA}},
    "relaxation": {"data": _data("relaxation", relaxation_start="auto"), "noise": {"sigma0": 0.3},
                   "truth": _truth(params={**HDPE, "sigma_inf": 20.0, "tau_max_R": 30.0}, strain_max=0.3,
                                   hold=100.0, n_points=200)},
    "cycles": {"data": _data("cycles"), "noise": {"sigma0": 0.3},
               "truth": {**{k: v for k, v in _truth().items() if k != "n_points"}, "strain_rate": 2e-3,
                         "strain_max": 0.06, "sample_rate": 1.0,
                         "cycles": {"count": 3, "unload_stress": 0.0}}},
    "joint": {"tests": [{"name": f"r{i}", "data": _data(f"r{i}"),
                         "noise": {"sigma0": 0.3, "discrepancy": "none"},
                         "truth": _truth(strain_rate=rate, seed=i, params={**HDPE, "tau_max": tau})}
                        for i, (rate, tau) in enumerate(((2.5e-3, 8.0), (1e-2, 4.0)))],
              "parameters": {**PRIORS, "tau_max": {**PRIORS["tau_max"], "per": "test"}}},
}


def _cli(*args: str) -> str:
    from bayes_dnlr.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(args))
    assert code == 0, (args, err.getvalue())
    return out.getvalue() + "\n" + err.getvalue()


def page_text(path: Path) -> str:
    """The page's words, one block element a line."""
    t = path.read_text(encoding="utf-8")
    t = re.sub(r"<(style|script).*?</\1>", "", t, flags=re.S)
    t = re.sub(r"<(br|/p|/li|/tr|/h\d|/div|/caption|/table)[^>]*>", "\n", t)
    t = re.sub(r"<[^>]+>", " ", t)
    return "\n".join(" ".join(line.split()) for line in html.unescape(t).splitlines() if line.strip())


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> dict[str, dict[str, Any]]:
    """name -> {dir, console, page, fit, summary, cfg}: the six runs, made once."""
    from bayes_dnlr.report import figure_cache

    root = tmp_path_factory.mktemp("one-voice")
    out = {}
    with pytest.MonkeyPatch.context() as mp:
        figures_not_drawn(mp)                                  # the page's words are read, not its figures
        mp.setattr(figure_cache, "_free_core", lambda: False)
        for name, raw in RUNS.items():
            d = root / name
            d.mkdir()
            (d / "config.yaml").write_text(yaml.safe_dump({"name": name, **raw, "sampler": SAMPLER},
                                                          sort_keys=False))
            config = str(d / "config.yaml")
            _cli("simulate", config)
            console = _cli("fit", config) + _cli("sample", config) + _cli("report", str(d))
            out[name] = {"dir": d, "console": console, "page": page_text(d / "report.html"),
                         "fit": json.loads((d / "fit.json").read_text()),
                         "summary": json.loads((d / "summary.json").read_text()), "raw": raw}
    return out


# ------------------------------------------------------------------------------ the stored values

def _leaves(x: Any, path: tuple = ()):
    if isinstance(x, dict):
        for k, v in x.items():
            yield from _leaves(v, (*path, str(k)))
    elif isinstance(x, list):
        for i, v in enumerate(x):
            yield from _leaves(v, (*path, str(i)))
    elif isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x):
        yield path, float(x)


def _param(key: str) -> bool:
    return base_name(key) in PARAMETER_NAMES


def stored(run: dict[str, Any]) -> dict[tuple[str, str], set[float]]:
    """(quantity, estimate) -> the values the run stores: parameters by estimate ('white', 'gls',
    'posterior', 'true', 'bound', 'fixed'), De_max ('white', 'posterior'), rms ('plain',
    'whitened'), sigma0 ('any')."""
    out: dict[tuple[str, str], set[float]] = {}

    def add(q: str, est: str, v: float) -> None:
        out.setdefault((q, est), set()).add(v)

    for path, v in _leaves(run["fit"]):
        last, parent = path[-1], path[-2] if len(path) > 1 else ""
        gls = "discrepancy" in path
        if _param(last) and parent == "estimate":
            add(last, "gls" if gls else "white", v)
        elif last == "deborah_max":
            add("De_max", "white", v)
        elif "rms" in last:
            add("rms", "whitened" if "whitened_residuals" in path else "plain", v)
        elif last == "sigma0":
            add("sigma0", "any", v)
    for path, v in _leaves(run["summary"]):
        last = path[-1]
        if path[0] == "posterior" and len(path) >= 3 and path[2] in ("mean", "median", "hdi_90"):
            add(path[1], "posterior", v)
        elif path[0] == "gauss_newton" and _param(last) and path[-2] == "estimate":
            add(last, "white", v)
        elif path[0] == "deborah_max":                 # the fit's, copied
            add("De_max", "white", v)
        elif path[0] == "deborah_max_posterior" and last == "mean":
            add("De_max", "posterior", v)
        elif last == "sigma0" or (path[0] == "posterior" and len(path) > 1 and path[1] == "sigma0"):
            add("sigma0", "any", v)
    raw = run["raw"]
    for t in raw.get("tests") or [raw]:
        for k, v in (t.get("truth") or {}).get("params", {}).items():
            add(k, "true", float(v))
        sigma0 = (t.get("noise") or {}).get("sigma0")
        if isinstance(sigma0, (int, float)):
            add("sigma0", "any", float(sigma0))
    for k, spec in {**PRIORS, **(raw.get("parameters") or {})}.items():
        for side in ("low", "high"):
            if side in spec:
                add(k, "bound", float(spec[side]))
    add("alpha", "fixed", 0.5)                     # left out: eq. 12's ½
    white_sd, gls_sd = run["fit"].get("sd") or {}, (run["fit"].get("discrepancy") or {}).get("sd") or {}
    for k, v in gls_sd.items():
        if white_sd.get(k):
            add(f"ratio:{k}", "gls", v / white_sd[k])
    interval = ((run["summary"].get("noise") or {}).get("interval") or {})
    if interval.get("sd_ratio_posterior_to_white") is not None:
        add(f"ratio:{interval['parameter']}", "posterior", interval["sd_ratio_posterior_to_white"])
    singles = [(f["estimate"]["E"], f["sd"]["E"]) for f in (run["fit"].get("single_fits") or {}).values()
               if (f.get("sd") or {}).get("E")]
    if singles:                                    # the paper's way: one E from the tests alone
        w = [1 / s**2 for _, s in singles]
        add("E", "white", sum(wi * e for wi, (e, _) in zip(w, singles, strict=True)) / sum(w))
    return out


# ------------------------------------------------------------------------------ the messages

NUMBER = r"[-+]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?"
PARAMETER = re.compile(r"(?<![\w\[(|/])(E|G|tau_max_R|tau_max|sigma_inf|alpha|σ∞|sigma0|σ0)(\[[^\]]+\])?"
                       rf"\s*=\s*({NUMBER})")
DEBORAH = re.compile(rf"De[ _]?max\b[^=;]*=[^=;]*=\s*((?:[\w.\-]+: )?{NUMBER}(?:, (?:[\w.\-]+: )?{NUMBER})*)")
RMS = re.compile(rf"\brms\b[^0-9\n;]{{0,45}}?({NUMBER})", re.IGNORECASE)
LABELS = {"posterior": ("posterior", "median", "hdi"), "white": ("white", "gauss-newton", "paper's", "alone"),
          "gls": ("model error", "gls", "generalized"), "true": ("true",), "bound": ("bound",),
          "fixed": ("fixed",)}


def clauses(text: str):
    """Each line cut at ';' and at a sentence's end, outside brackets."""
    for line in text.splitlines():
        depth, start = 0, 0
        for i, c in enumerate(line):
            depth += c in "([{"
            depth -= c in ")]}"
            end = c == ";" or (c == "." and line[i + 1:i + 3].startswith(" ") and line[i + 2:i + 3].isupper()
                               and line[i - 1:i].isalpha() or c == "." and line[i - 1:i] == ")"
                               and line[i + 1:i + 2] == " ")
            if depth <= 0 and end:
                yield line[start:i]
                start = i + 1
                depth = 0
        yield line[start:]


CITATION = re.compile(r"the paper's table|the paper finds|\(the paper:")


def _labels(clause: str) -> set[str]:
    low = clause.lower()
    found = {k for k, words in LABELS.items() if any(w in low for w in words)}
    if "least squares" in low and not found & {"white", "gls"}:
        found |= {"white", "gls"}
    return found


def _close(printed: str, values: set[float]) -> bool:
    mant = printed.lower().split("e")[0]
    decimals = len(mant.split(".")[1]) if "." in mant else 0
    exp = int(printed.lower().split("e")[1]) if "e" in printed.lower() else 0
    tol = 0.5 * 10.0 ** (exp - decimals) * (1 + 1e-9)
    x = float(printed)
    return any(abs(x - v) <= tol + 1e-12 * abs(v) for v in values)


def _values(store: dict, quantity: str, labels: set[str]) -> set[float]:
    out: set[float] = set()
    for (q, est), vals in store.items():
        if (q == quantity or (base_name(q) == quantity and "[" in q)) and (est in labels or est == "any"):
            out |= vals
    return out


RATIO = re.compile(rf"(?:(\b{'|'.join(sorted(PARAMETER_NAMES, key=len, reverse=True))}) )?({NUMBER})x\b")


def ratio_mismatches(text: str, store: dict) -> list[str]:
    """Every ratio of sd written otherwise than ``2.01x`` with what it divides by, and every ratio to
    the white sd that is not the stored one of its estimate (the parameter before it, else E)."""
    bad = [f"x before its number: {m[0]!r}" for m in re.finditer(r"(?<![\w.])x\d", text)]
    for clause in clauses(text):
        for m in RATIO.finditer(clause):
            after = clause[m.end():m.end() + 12]
            if "white one" not in clause:
                if not re.match(r" (the|sigma0)\b", after):
                    bad.append(f"a ratio without what it divides by: {m[0]!r} in {clause.strip()!r}")
                continue
            labels = _labels(clause) & {"gls", "posterior"} or {"gls", "posterior"}
            vals = _values(store, f"ratio:{m[1] or 'E'}", labels)
            if not _close(m[2], vals):
                bad.append(f"ratio {m[0]!r} is none of {sorted(vals)}: {clause.strip()!r}")
    return bad


# the exponent's own pull: "pull alpha by -2.35" (an exponent of -1.85), not "pull the spectrum's
# exponent to 0.25 (...), which moves E(5.00 s) by -109 MPa" (a value of it, and what E(t) does)
PULL = re.compile(rf"pulls? (?:alpha|the spectrum's exponent)(?: away from \S+)? by (?>({NUMBER}))(?! sd)")


def word_mismatches(text: str) -> list[str]:
    """The words that misled: a kernel's weight without what the weights weigh, the exponent's pull
    as a step of the exponent (an exponent of ½ "pulled by -2.35"), a literal '...' to fill in."""
    bad = []
    for line in text.splitlines():
        if re.search(r"\b(exp|matern32) \d+(\.\d+)? %", line) and "whatever the weights" not in line:
            bad.append(f"kernel weights without what they weigh: {line.strip()!r}")
        for m in re.finditer(PULL, line):
            bad.append(f"the exponent's pull not in sd: {m[0]!r}")
        if re.search(r"value: \.\.\.", line):
            bad.append(f"a value left as '...': {line.strip()!r}")
    return bad


def quotes(text: str) -> int:
    """How many values the checks below read in ``text``."""
    return sum(len(PARAMETER.findall(c)) + len(DEBORAH.findall(c)) + len(RMS.findall(c))
               for c in clauses(text) if not CITATION.search(c.lower()))


def mismatches(text: str, store: dict) -> list[str]:
    """Every quoted number that is not what the run stores for the estimate its clause names."""
    bad = []
    for clause in clauses(text):
        if CITATION.search(clause.lower()):          # the paper's own figures, quoted as such
            continue
        labels = _labels(clause)
        for m in PARAMETER.finditer(clause):
            q = {"σ∞": "sigma_inf", "σ0": "sigma0"}.get(m[1], m[1]) + (m[2] or "")
            if q.startswith("sigma0"):
                vals = _values(store, "sigma0", {"any"})
            elif not labels:
                bad.append(f"unlabelled: {m[0]!r} in {clause.strip()!r}")
                continue
            else:
                vals = _values(store, q, labels)
            if not _close(m[3], vals):
                bad.append(f"{m[0]!r} ({', '.join(sorted(labels)) or 'any'}) is none of {sorted(vals)}: "
                           f"{clause.strip()!r}")
        for m in DEBORAH.finditer(clause):
            if not labels & {"white", "gls", "posterior"}:
                bad.append(f"unlabelled De_max: {clause.strip()!r}")
                continue
            vals = _values(store, "De_max", labels)
            for x in re.findall(NUMBER + r"(?=,|$)", m[1].replace(" ", "")):
                if not _close(x, vals):
                    bad.append(f"De_max {x} is none of {sorted(vals)}: {clause.strip()!r}")
        for m in RMS.finditer(clause):
            kind = "whitened" if "whitened" in clause.lower() else "plain"
            vals = _values(store, "rms", {kind})
            if not _close(m[1], vals):
                bad.append(f"rms {m[1]} ({kind}) is none of {sorted(vals)}: {clause.strip()!r}")
    return bad


# ------------------------------------------------------------------------------ the tests

def test_the_clauses_and_labels_read_as_meant():
    store = {("E", "posterior"): {2869.2}, ("E", "white"): {2868.0}, ("rms", "plain"): {0.2808},
             ("rms", "whitened"): {9.43}, ("De_max", "white"): {0.02922}}
    assert not mismatches("E = 2869 ± 28 MPa (posterior mean ± sd; 90 % HDI [2826, 2916]); white-noise "
                          "least squares (the paper's) 2868 ± 28 MPa.", store)
    assert mismatches("E = 2868 MPa (posterior mean)", store)                      # another estimate
    assert mismatches("E = 2869 MPa sits on a line", store)[0].startswith("unlabelled")
    assert mismatches("The rms residual (9.43 MPa) is 9.4x sigma0", store)          # the whitened rms
    assert not mismatches("The rms of the whitened residuals (9.43, no unit) is 9.4x the 1", store)
    assert not mismatches("De_max = tau_max · rate = 0.02922 (eq. 45, white least squares)", store)
    assert mismatches("De_max = tau_max · rate = 0.02922 (eq. 45)", store)
    ratios = {("ratio:E", "posterior"): {2.0109}, ("ratio:E", "gls"): {2.025}, ("ratio:G", "gls"): {10.19}}
    assert not ratio_mismatches("E moves by +17.9 white sd; its sd, 2.01x the white one (wider)", ratios)
    assert not ratio_mismatches("the estimate: generalized least squares; its sd, against the white one: "
                                "E 2.03x, G 10.19x", ratios)
    assert ratio_mismatches("its sd, 2.39x the white one", ratios)                 # not the stored one
    assert ratio_mismatches("sd widened by the kernels' model of the error: E x5.01", ratios)
    assert not ratio_mismatches("The rms residual (9.43 MPa) is 9.4x sigma0", ratios)
    assert word_mismatches("the interval's width: kernel auto mixes the kernels, weights exp 0 %")
    assert word_mismatches("the data pull alpha by -2.35 ± 0.22 (-10.8 sd, white noise)")
    assert not word_mismatches("the data pull alpha away from ½ by -10.8 sd (score test, white noise)")
    assert not word_mismatches("the data pull the spectrum's exponent to 0.25 (eq. 12 holds it at ½), "
                               "which moves E(5.00 s) by -109 MPa")


@pytest.mark.parametrize("name", list(RUNS))
def test_every_quoted_number_is_the_stored_one_of_the_estimate_it_names(runs, name):
    run = runs[name]
    store = stored(run)
    bad = mismatches(run["console"], store) + mismatches(run["page"], store)
    bad += ratio_mismatches(run["console"], store) + ratio_mismatches(run["page"], store)
    assert not bad, "\n".join(bad)
    assert quotes(run["console"]) >= 1 and quotes(run["page"]) >= 3      # De_max; E, De_max, the rms


@pytest.mark.parametrize("name", list(RUNS))
def test_the_words_say_what_their_numbers_are(runs, name):
    run = runs[name]
    bad = word_mismatches(run["console"]) + word_mismatches(run["page"])
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize("name", list(RUNS))
def test_a_verdict_leads_with_its_decision_then_the_checks_that_fail(runs, name):
    """Never "The model describes this test, but do not use ..." above a point that says the model's
    form does not fit, nor the predictive band's good news first in a verdict that does not trust."""
    console, checks = runs[name]["console"], runs[name]["summary"]["checks"]
    lines = console.splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith("verdict: "))
    head = lines[at].removeprefix("verdict: ")
    if checks["trust_interval"]:
        assert head.startswith("Use E's interval as it is.")
        return
    assert head.startswith(("Do not use E's interval", "The model does not describe")), head
    assert "describes" not in head.replace("does not describe", "")
    first = lines[at + 1].removeprefix("  - ")
    assert not re.search(r"predictive band holds \d+ % of the points \(80-97 % expected\)", first), first


@pytest.mark.parametrize("name", list(RUNS))
def test_verdict_is_the_word_of_the_checks_verdict_only(runs, name):
    page = runs[name]["page"]
    lines = [line for line in page.splitlines() if re.match(r"verdict\b", line, re.IGNORECASE)]
    assert all(line.startswith("Verdict of the checks") for line in lines), lines


def test_a_joint_run_speaks_of_its_tests(runs):
    checks = runs["joint"]["summary"]["checks"]
    assert "this test" not in checks["verdict"]
    assert "these tests" in checks["verdict"] or checks["verdict"].startswith("Use E's interval")


def test_the_prior_sensitivity_with_alpha_sampled_is_arviz_stats_psense(runs):
    """The reference: psense on the posterior draws with the priors as the config gives them
    (scipy's densities: E and G uniform, tau_max log-uniform, alpha a truncated normal)."""
    ab = pytest.importorskip("arviz_base")
    psense = pytest.importorskip("arviz_stats").psense
    from scipy import stats

    from bayes_dnlr.runs.results import read_draws

    run = runs["alpha"]
    draws = read_draws(run["dir"] / "posterior.nc")
    mine = run["summary"]["checks"]["prior_sensitivity"]
    a, b = (ALPHA["low"] - ALPHA["mean"]) / ALPHA["sd"], (ALPHA["high"] - ALPHA["mean"]) / ALPHA["sd"]
    dens = {"E": stats.uniform(100, 19900), "G": stats.uniform(0, 50), "tau_max": stats.loguniform(0.01, 1e4),
            "alpha": stats.truncnorm(a, b, ALPHA["mean"], ALPHA["sd"])}
    log_prior = sum(dens[k].logpdf(draws[k]) for k in mine)
    tree = ab.from_dict({"posterior": {k: draws[k] for k in mine}, "log_prior": {"lp": log_prior},
                         "log_likelihood": {"obs": np.zeros_like(log_prior)}})
    ref = psense(tree, group="prior")
    assert set(mine) == set(dens)
    for k in mine:
        assert mine[k] == pytest.approx(float(ref[k]), rel=1e-6, abs=1e-9), k
    assert mine["E"] > 0 and mine["alpha"] > 0
