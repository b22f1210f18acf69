"""The references in ``sample`` (summary.json ``reference_moduli`` and ``reference_curve``): every
reference's prediction at its time scale from the kept posterior draws, and the curve of E'(ω),
E''(ω) the report's Table 4 draws."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from bayes_dnlr.config import Config
from bayes_dnlr.inference.references import compare
from bayes_dnlr.inference.references.condition import parameter_map
from bayes_dnlr.inference.references.terms import Reference, predict
from bayes_dnlr.runs.reference_moduli import entry, name_function, references_of

MAX_DRAWS = 20000          # the posterior's prediction from at most this many kept draws (evenly spread)
CURVE_DRAWS = 400          # the report's E'(ω), E''(ω) curve: draws and frequencies
CURVE_POINTS = 100


def summary_references(cfg: Config, names: list[str], draws: np.ndarray, plain: bool,
                       fit: Mapping[str, Any] | None = None
                       ) -> tuple[list[dict[str, Any]] | None, dict[str, Any] | None]:
    """summary.json ``reference_moduli``: every reference's prediction from the kept draws
    (steps, walkers, ndim), at most MAX_DRAWS of them; and ``reference_curve``, E'(ω) and E''(ω)
    quantiles for the report's figure. (None, None) without references."""
    refs = references_of(cfg)
    if not refs:
        return None, None
    name_of = name_function(cfg, plain)
    flat = draws.reshape(-1, draws.shape[-1])
    if flat.shape[0] > MAX_DRAWS:
        flat = flat[np.linspace(0, flat.shape[0] - 1, MAX_DRAWS).astype(int)]
    held = {k: float(v["value"]) for k, v in (((fit or {}).get("identifiability") or {}).get("held")
                                               or {}).items()}
    fixed = {**cfg.fixed_values, **held}
    out = []
    first_cols = None
    for ref in refs:
        cols: dict[str, Any] = {}
        for k, g in parameter_map(ref, names, name_of).items():
            if g in names:
                cols[k] = flat[:, names.index(g)]
            elif k in fixed:
                cols[k] = float(fixed[k])
        e = cols.get("E")
        e_stats = (None if e is None else {"mean": float(np.mean(e)), "sd": float(np.std(e, ddof=1))}
                   if np.ndim(e) else {"mean": float(e), "sd": 0.0})
        point = {k: float(np.median(v)) if np.ndim(v) else float(v) for k, v in cols.items()}
        pred = None
        if ref.predictable and {"E", "tau_max"} <= set(cols):
            pred = compare.from_draws(predict(ref, cols, cfg.model.modes, cfg.model.decades))
            first_cols = first_cols or cols
        out.append(entry(ref, pred, e_stats, point, cfg.model.decades))
    curve = None if first_cols is None else _curve(refs, first_cols, cfg)
    return out, curve


def _curve(refs: Sequence[Reference], cols: Mapping[str, Any], cfg: Config) -> dict[str, Any]:
    """E'(ω), E''(ω) quantiles (5, 50, 95 %) over CURVE_DRAWS draws on CURVE_POINTS frequencies from
    well below the references' and the spectrum's to where every mode is frozen; E's median and
    90 % HDI: what the report draws (it computes no model)."""
    from bayes_dnlr.model.modulus import FROZEN, complex_modulus

    n = max(np.size(v) for v in cols.values())
    pick = np.linspace(0, n - 1, min(CURVE_DRAWS, n)).astype(int)
    sub = {k: (np.asarray(v)[pick] if np.ndim(v) else v) for k, v in cols.items()}
    tau = float(np.median(sub["tau_max"]))
    freq = [float(f) for r in refs for q, f in zip(r.quantity, r.at, strict=True)
            if q in ("storage", "loss")]
    freq += [1.0 / (2 * np.pi * float(t)) for r in refs for q, t in zip(r.quantity, r.at, strict=True)
             if q == "relaxation"]
    low = min([0.1 / (2 * np.pi * tau), *(0.3 * f for f in freq)])
    frozen = FROZEN / (2 * np.pi * tau * 10.0 ** (-cfg.model.decades))
    high = max([3.0 * frozen, *(3.0 * f for f in freq)])
    grid = np.geomspace(low, high, CURVE_POINTS)
    storage, loss = complex_modulus(grid, sub["E"], sub.get("G", 0.0), sub["tau_max"],
                                    sub.get("alpha", 0.5), cfg.model.modes, cfg.model.decades)
    qs = np.quantile(np.atleast_2d(storage), [0.05, 0.5, 0.95], axis=0)
    ql = np.quantile(np.atleast_2d(loss), [0.05, 0.5, 0.95], axis=0)
    e = np.asarray(cols["E"], dtype=float).ravel()
    lo, hi = compare.from_draws(e[:, None]).hdi[0]
    return {"frequency": grid.tolist(), "storage": qs.tolist(), "loss": ql.tolist(),
            "E_median": float(np.median(e)), "E_hdi_90": [float(lo), float(hi)],
            "frozen_above": float(frozen)}
