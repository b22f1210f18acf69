"""The ``noise`` block of summary.json: which noise model the posterior used, its hyperparameters, and
the interval of E under white noise and under the model discrepancy, with a verdict in words.

The white interval is the paper's linearized one (fit.json, eq. 32: estimate ± 1.645 sd, which the
white posterior matches to a few percent on white data, docs/sampling.md); the discrepancy interval
is the posterior's 90 % HDI. docs/model-error.md explains why they differ; the run's checks
(summary.json `checks`) decide which is trusted.
"""

from __future__ import annotations

import math
from typing import Any

from bayes_dnlr.config import Config
from bayes_dnlr.inference.discrepancy.hyper import AMPLITUDE, LENGTH
from bayes_dnlr.inference.discrepancy.kernel_mix import mix_words
from bayes_dnlr.inference.layout import Layout
from bayes_dnlr.runs.records import Analysis, FitRecord
from bayes_dnlr.vocabulary import Z90


def _linearized(estimate: float | None, sd: float | None) -> dict[str, Any] | None:
    if estimate is None or sd is None or not math.isfinite(sd):
        return None
    return {"estimate": estimate, "sd": sd, "interval_90": [estimate - Z90 * sd, estimate + Z90 * sd]}


def _of(analysis: Analysis | None, name: str) -> dict[str, Any] | None:
    """The linearized interval of the run's parameter ``name`` in one of the run's analyses."""
    if analysis is None:
        return None
    return _linearized(analysis.estimate.get(name), analysis.sd.get(name))


def _hyper(name: str, summary: dict[str, Any], fixed: float | None) -> dict[str, Any] | None:
    post = (summary.get("posterior") or {}).get(name)
    if post is not None:
        return {"sampled": True, **{k: post[k] for k in ("mean", "sd", "median", "hdi_90")}}
    return None if fixed is None else {"sampled": False, "value": fixed}


def noise_block(cfg: Config, fit: dict[str, Any], summary: dict[str, Any], sigma0: float,
                sigma0_source: str, parameter: str = "E",
                run: tuple[Analysis | None, Analysis | None, str] | None = None) -> dict[str, Any]:
    """The ``noise`` block of summary.json (docs/sampling.md) of one test: its noise from its own
    fit ``fit``; the linearized intervals of ``parameter`` from ``run`` (the run's white and
    generalized analyses and the parameter's name in them; None: the test's own fit is the run's),
    so that the posterior is set beside the analyses of its own likelihood."""
    disc = fit.get("discrepancy") if cfg.noise.has_discrepancy else None
    switched_off = bool(disc) and not disc.get("evidence") and cfg.noise.discrepancy.amplitude is None
    white_fit = (fit.get("residuals") or {}).get("white")
    post = (summary.get("posterior") or {}).get(parameter)
    if run is None:
        run = (Analysis.from_dict(fit, list(fit.get("parameters") or [])),
               Analysis.from_dict(disc, list(fit.get("parameters") or [])), parameter)
    run_white, run_gls, name = run
    white = _of(run_white, name)
    block: dict[str, Any] = {
        "model": "discrepancy" if disc and not switched_off else "white",
        "sigma0": _hyper("sigma0", summary, sigma0) | {"source": sigma0_source},
        "fit_residuals_white": white_fit,
    }
    if disc:
        block["likelihood_ratio"] = disc.get("likelihood_ratio")
        block["evidence_of_model_error"] = disc.get("evidence")
    interval: dict[str, Any] = {"parameter": parameter, "white_linearized": white}
    if disc:
        hyper = disc.get("hyperparameters") or {}
        block.update({
            "kernel": disc.get("kernel"), "axis": disc.get("axis"), "axis_unit": disc.get("axis_unit"),
            "amplitude": _hyper(AMPLITUDE, summary, hyper.get("amplitude")),
            "length": _hyper(LENGTH, summary, hyper.get("length")),
            "priors": disc.get("priors"),
            "maximum_likelihood": hyper,
        })
        choice = disc.get("kernel_choice")
        if choice:
            block["kernel_choice"] = {k: choice[k] for k in ("reason", "weights",
                                                             "log_likelihood_gain_matern32",
                                                             "move_in_sd") if k in choice}
        interval["gls_linearized"] = _of(run_gls, name)
    if post is not None:
        interval["posterior"] = {k: post[k] for k in ("mean", "sd", "hdi_90")}
        interval["posterior_likelihood"] = block["model"]
    if white and post is not None and white["sd"] > 0:
        interval["sd_ratio_posterior_to_white"] = post["sd"] / white["sd"]
        interval["shift_in_white_sd"] = (post["mean"] - white["estimate"]) / white["sd"]
    block["interval"] = interval
    block["verdict"] = verdict(block)
    return block


def verdict(block: dict[str, Any]) -> str:
    """How the two intervals relate, in words (the checks, not this text, decide trust)."""
    iv = block["interval"]
    p = iv["parameter"]
    white, post = iv.get("white_linearized"), iv.get("posterior")
    resid_white = block.get("fit_residuals_white")
    if block["model"] == "white":
        lr = block.get("likelihood_ratio")
        if lr is not None and not block.get("evidence_of_model_error"):
            return (f"No evidence of model error: the discrepancy raises the likelihood by "
                    f"2 Δ log L = {lr:.3g} ≤ 9.21 (the 99 % point of χ²₂), so its amplitude is 0 and "
                    f"the posterior is the white one; the interval of {p} needs no widening.")
        if resid_white is False:
            return (f"The residuals of the fit are not white, yet this posterior assumes white noise "
                    f"(noise.discrepancy: none): its interval of {p} ignores the model error and is "
                    "too narrow. Sample with the discrepancy (the default) for an honest interval.")
        return (f"The residuals look like noise: the white likelihood's interval of {p} is "
                "appropriate.")
    if post is None or white is None:
        return "The posterior used the model-discrepancy likelihood."
    ratio = iv.get("sd_ratio_posterior_to_white", float("nan"))
    shift = iv.get("shift_in_white_sd", float("nan"))
    amp = block.get("amplitude") or {}
    if resid_white:
        return (f"The residuals look like noise and the discrepancy stays small (amplitude "
                f"{amp.get('mean', amp.get('value', 0.0)):.3g} MPa): the discrepancy interval of {p} "
                f"is {ratio:.2f}x the white one and the estimate moved by {shift:+.1f} white sd; "
                "both describe these data.")
    width = ("wider" if ratio >= 1 else "narrower: the whitened fit weighs the curve's shape "
             "sample to sample, not its level, and the shape can pin the parameters better than the "
             "level does (docs/model-error.md)")
    proj = block.get("projection")
    if proj and "sd_factor" in proj:
        w = proj.get("kernel_weights") or {}
        return (f"The residuals of the white fit are signed waves (model error), which the white "
                f"likelihood takes for independent noise: its interval of {p} (90 % half-width "
                f"{Z90 * white['sd']:.4g}) rests on that, and its centre is where the waves pull the "
                f"parameters. The estimate under model error fits the curve in the metric of an "
                f"Ornstein-Uhlenbeck discrepancy (slopes as much as levels): {p} moves by "
                f"{shift:+.1f} white sd; its sd, {ratio:.2f}x the white one ({width}), is that of this "
                f"estimate under {mix_words(w, str(block.get('kernel')))}. Whether to use the "
                "interval is the checks' verdict.")
    if proj:
        offset = (proj.get("sd_offset_u") or {}).get(p)
        return (f"The residuals of the white fit are signed waves (model error), which the white "
                f"likelihood takes for independent noise: its interval of {p} (90 % half-width "
                f"{Z90 * white['sd']:.4g}) is that of the least-squares projection of the curve onto "
                f"the model, not of {p} itself. The discrepancy keeps the projection as the centre "
                f"and adds what the data cannot tell from a change of {p}, the part of the model "
                f"error along the sensitivities (its projection offset): the sd is {ratio:.2f}x the "
                f"white one ({width})" + (f", the offset's sd {offset:.3g} (in {p}'s sampling units)"
                                          if offset is not None else "") + ". Its width is set by "
                "the kernel's model of the error; whether to use it is the checks' verdict.")
    return (f"The residuals of the white fit are signed waves (model error), which the white "
            f"likelihood takes for independent noise: its interval of {p} (90 % half-width "
            f"{Z90 * white['sd']:.4g}) rests on that, and its centre is where the waves pull the "
            f"parameters. With the discrepancy the waves are attributed to δ: {p} moves by "
            f"{shift:+.1f} white sd and its sd is {ratio:.2f}x the white one ({width}). Whether to "
            f"use the interval is the checks' verdict.")


def residual_warnings(fit: dict[str, Any]) -> list[str]:
    """The fit's warnings about its residuals and the discrepancy, carried into sample's output."""
    keys = ("residuals are not white", "whitened residuals", "discrepancy")
    return [w for w in (fit.get("warnings") or []) if any(k in w for k in keys)]


def noise_summary(cfg: Config, fit: dict[str, Any], summary: dict[str, Any], layout: Layout,
                  sigma0: dict[str, float], sigma0_source: dict[str, str]) -> dict[str, Any]:
    """The ``noise`` block of a run's summary.json: each test's own block (its hyperparameters, E's
    interval under white noise and under the discrepancy); a run with one test writes its block
    itself, a run with several puts them under ``tests`` with a verdict over all. E's intervals
    are the run's (its joint analyses beside its joint posterior): like with like."""
    post = summary.get("posterior") or {}
    singles = fit.get("single_fits") or {}
    record = FitRecord.from_dict(fit, layout.tests)
    blocks = {}
    for t in layout.tests:
        local = {k: post[layout.name(k, t)] for k in layout.local[t] if layout.name(k, t) in post}
        own = fit if layout.plain else singles.get(t) or {}
        blocks[t] = noise_block(cfg.for_test(t), own, {"posterior": local}, sigma0.get(t),
                                sigma0_source.get(t, ""),
                                run=(record.white, record.generalized, layout.name("E", t)))
    if layout.plain:
        return layout.collapse(blocks)
    models = {b["model"] for b in blocks.values()}
    groups: dict[str, list[str]] = {}
    for t, b in blocks.items():
        silent = (b["model"] == "white" and b.get("likelihood_ratio") is not None
                  and not b.get("evidence_of_model_error"))
        kind = "no evidence of model error" if silent else b["verdict"]
        groups.setdefault(kind, []).append(t)
    words = []
    for kind, tests in groups.items():
        if kind == "no evidence of model error":
            words.append(f"{', '.join(tests)}: no evidence of model error (2 Δ log L ≤ 9.21): white "
                         "likelihood.")
        else:
            words.append(f"{', '.join(tests)}: {kind}")
    return {"model": "discrepancy" if "discrepancy" in models else "white", "tests": blocks,
            "verdict": " ".join(words)}
