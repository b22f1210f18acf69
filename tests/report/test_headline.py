"""The top of the report: a standard modulus that cannot be computed on a curve says so in the
headline, and a run with several tests carries every test's own warnings (the kernel choice, a
parameter on its bound, a hint about the data), each named with its test."""

from __future__ import annotations

import html
import re

from support.joint import RATES, make_joint
from support.runs import make_run, ramp_truth

from bayes_dnlr.config import load_config
from bayes_dnlr.report import build_report
from bayes_dnlr.report.headline import warnings
from bayes_dnlr.runs.fit import fit
from bayes_dnlr.runs.results import RunResults

KERNEL = ("kernel auto kept exp: matern32 fits better (log-likelihood +12) but moves E by 13.0 "
          "combined sd: the smooth discrepancy absorbs the model's response, so exp is kept")
BOUND = "G = 0 is on its bound (parameters.G.low): widen the prior or fix G"
HINT = "the stress column looks like an engineering stress: observable: stress takes it as true"


def _headline(page: str) -> str:
    return re.search(r'<div class="box">(.*?)</div>', page, re.S).group(1)


def test_a_missing_standard_reaches_the_headline(tmp_path):
    """50 samples to strain 1: none in ISO 527-1's 0.05-0.25 %, so no ISO modulus."""
    path = make_run(tmp_path, "coarse", ramp_truth(1.0, n_points=50, stress_sd=0.3), sigma0=0.3)
    fit(load_config(path))
    head = html.unescape(_headline(build_report(path.parent).read_text()))
    assert "ISO 527-1 is not available on this curve" in head
    assert "E = " in head


def test_every_tests_warnings_are_on_the_page_of_a_joint_run(tmp_path):
    cfg = load_config(make_joint(tmp_path))
    names = ["E", "G", *(f"tau_max[{t}]" for t in RATES)]
    own = {"estimate": {"E": 2854.0, "G": 2.32, "tau_max": 5.0}, "sd": {"E": 30.0, "G": 0.01, "tau_max": 0.1},
           "residuals": {"white": True}, "sigma0": 0.1}
    singles = {t: {**own, "warnings": []} for t in RATES}
    singles["r5e-3"]["warnings"] = [KERNEL, HINT]
    singles["r1e-2"]["warnings"] = [BOUND]
    joint = {"joint": True, "parameters": names, "per_test": ["tau_max"],
             "estimate": {"E": 2854.0, "G": 2.32, **{f"tau_max[{t}]": 5.0 for t in RATES}},
             "sd": dict.fromkeys(names, 0.1), "single_fits": singles,
             "tests": {t: {"n_points": 150, "residuals": {"white": True}} for t in RATES},
             "warnings": ["r5e-3: " + HINT, "strongly correlated pairs (|ρ| > 0.99): E–tau_max[r5e-3]"]}
    out = warnings(RunResults(run_dir=tmp_path / "joint", cfg=cfg, fit=joint))
    assert "r5e-3: " + KERNEL in out and "r1e-2: " + BOUND in out
    assert out.count("r5e-3: " + HINT) == 1                 # the run's copy of it is not repeated
    assert "strongly correlated pairs (|ρ| > 0.99): E–tau_max[r5e-3]" in out
    assert KERNEL not in out and BOUND not in out           # never without its test's name


def test_the_checks_verdict_sits_under_the_headline(tmp_path):
    """A sampled run's checks decide the colour of the box under the headline and give its words."""
    import json

    from support.finished_run import make_finished_run

    run = make_finished_run(tmp_path, figures=True)        # its figures drawn: only the page is built
    summary = json.loads((run / "summary.json").read_text())
    points = summary["checks"]["verdict_points"]          # the verdict after its first sentence
    assert points and summary["checks"]["verdict"].endswith(" ".join(points))
    page = build_report(run).read_text()
    box = re.search(r'<div class="box (ok|warn)"><b>Verdict</b>(.*?)</div>', page, re.S)
    assert box is not None
    assert box.group(1) == ("ok" if summary["checks"]["trust_interval"] else "warn")
    assert _words(box.group(2)).endswith(" ".join(summary["checks"]["verdict"].split()))


def _words(fragment: str) -> str:
    """The text of an HTML fragment, its tags as spaces, its white space single."""
    return " ".join(html.unescape(re.sub(r"<[^>]+>", " ", fragment)).split())


def test_each_finding_of_the_checks_is_an_item_of_its_own():
    """Four findings in one paragraph were read as one: the first sentence in bold, then one item
    per check; a summary.json of a version without the points keeps the paragraph."""
    from types import SimpleNamespace

    from bayes_dnlr.report.headline import checks_box

    head = "The model does not describe this test: E's interval is not reliable."
    points = ["The 90 % predictive band holds 12 % of the points.",
              "The posterior of G piles against its prior's high bound (50.00) & more."]
    checks = {"trust_interval": False, "verdict": " ".join([head, *points]), "verdict_points": points}
    box = checks_box(SimpleNamespace(summary={"checks": checks}))
    assert box.startswith('<div class="box warn"><b>Verdict</b>')
    assert f"<b>{html.escape(head)}</b><ul>" in box
    assert re.findall(r"<li>(.*?)</li>", box) == [html.escape(p) for p in points]
    assert _words(box).endswith(checks["verdict"])
    old = {k: v for k, v in checks.items() if k != "verdict_points"}
    box = checks_box(SimpleNamespace(summary={"checks": old}))
    assert "<li>" not in box and box.endswith(html.escape(checks["verdict"]) + "</div>")
