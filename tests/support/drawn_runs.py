"""Finished single-test runs made without sampling, for the commands that read many of them
(population, compare, a batch's page): a config (its data file need not exist), a summary.json
with the posterior, the checks' verdict and (optionally) E(t), and a posterior.nc of normal draws.

The checks follow summary.json's contract (docs/sampling.md, "Checks and verdict"); ``modulus_at``
the one-test form of E(t) at chosen times (a list of entries)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

CONFIG = """name: {name}
{material}data:
  file: missing.csv
  columns: {{time: t_s, strain: eps, stress: s}}
  observable: stress
"""
TRUSTED = "Use E's interval as it is."
NOT_TRUSTED = "The model describes this test, but do not use E's interval as it is."
MODEL_FORM_POINT = ("The data pull the spectrum's exponent away from Cunat's ½ by -3.1 sd (score "
                    "test, under the discrepancy): the model's form does not fit.")
COVERAGE_POINT = "The 90 % predictive band holds 90 % of the points (80-97 % expected)."


def checks(trust: bool) -> dict[str, Any]:
    """A one-test checks block: all passed, or the model-form score test failed."""
    points = [COVERAGE_POINT] + ([] if trust else [MODEL_FORM_POINT])
    head = TRUSTED if trust else NOT_TRUSTED
    return {"predictive_coverage": {"overall": 0.9, "points": 250, "segments": {
                "time block 1": {"share": 0.9, "points": 50}}, "E_weighted": 0.9},
            "bound_limited": [], "prior_sensitivity": {"E": 0.0, "G": 0.0, "tau_max": 0.0},
            "plausibility": {"tau_max": {"ok": True, "median": 6.0, "test_duration": 200.0}},
            "model_form": {"z": 0.1 if trust else -3.1, "ok": trust, "likelihood": "under the discrepancy"},
            "noise_model": {"likelihood": "white", "residuals_white": True, "ok": True},
            "prior_sources": {}, "adequate": True, "trust_interval": trust,
            "verdict": " ".join([head, *points]), "verdict_points": points}


def modulus_entry(t: float, mean: float, sd: float, trust: bool = True,
                  resolved: tuple[float, float] = (0.5, 200.0)) -> dict[str, Any]:
    """An entry of ``modulus_at``: E(t) at ``t``, the test resolving ``resolved`` (s)."""
    return {"t": t, "mean": mean, "sd": sd, "median": mean, "hdi_90": [mean - 1.645 * sd, mean + 1.645 * sd],
            "resolved": list(resolved), "trust": trust,
            "trust_reasons": [] if trust else ["E's interval is not trusted"]}


def drawn_run(root: Path, name: str, e: float, sd: float, *, material: str | None = None,
              trust: bool | None = True, modulus: list[dict[str, Any]] | None = None,
              rate: float = 5e-3, seed: int = 0) -> Path:
    """``root/name``: a finished run whose E posterior is Normal(e, sd) (16 walkers x 400 draws);
    ``trust`` None: a run without checks (an earlier version)."""
    from bayes_dnlr.runs.outputs import build_datatree

    d = root / name
    d.mkdir(parents=True)
    text = CONFIG.format(name=name, material=f"material: {material}\n" if material else "")
    (d / "config.yaml").write_text(text)
    rng = np.random.default_rng(seed)
    values = {"E": rng.normal(e, sd, (400, 16)), "G": rng.normal(2.3, 0.01, (400, 16)),
              "tau_max": rng.normal(6.0, 0.05, (400, 16))}
    names = list(values)
    post = {k: {"mean": float(v.mean()), "sd": float(v.std(ddof=1)), "median": float(np.median(v)),
                "hdi_90": [float(np.quantile(v, 0.05)), float(np.quantile(v, 0.95))],
                "ess_bulk": 1000.0, "ess_tail": 1000.0, "r_hat": 1.001} for k, v in values.items()}
    summary: dict[str, Any] = {"name": name, "parameters": names, "posterior": post, "converged": True,
                               "fingerprint": f"fp-{name}-{seed}", "strain_rate": rate,
                               "standards": {"iso527_1": 0.7 * e, "astm_d638": 0.6 * e}}
    if trust is not None:
        summary["checks"] = checks(trust)
    if modulus is not None:
        summary["modulus_at"] = modulus
    (d / "summary.json").write_text(json.dumps(summary))
    fit = {"parameters": names, "estimate": {"E": e, "G": 2.3, "tau_max": 6.0},
           "sd": {"E": sd, "G": 0.01, "tau_max": 0.05}, "strain_rate": rate, "deborah_max": 6.0 * rate}
    (d / "fit.json").write_text(json.dumps(fit))
    draws = np.stack([values[k] for k in names], axis=-1)
    build_datatree(names, draws, np.zeros((400, 16))).to_netcdf(d / "posterior.nc", engine="h5netcdf")
    return d
