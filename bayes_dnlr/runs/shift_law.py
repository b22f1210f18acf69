"""The trust of a temperature law: each temperature's tests predicted from the others.

A shift law fitted to tests at several temperatures can describe every one of them and still be
wrong: a tau_max and an Ea (or C1, C2) that trade against each other fit any set of curves as
well as the right pair. Only a temperature the law was not fitted to tells. So, for each
temperature, the run is fitted again without its tests (the same joint least squares, from the
same config), and the held-out tests are predicted from that fit's Laplace draws. A point-wise
band is no test here: the prediction's error is one error of the parameters, shared by every point
(a draw 1.5 sd off puts a third of a test outside a 90 % band). The test is the held-out residual's
Mahalanobis distance, q = rᵀ(S + V)⁻¹r, S the draws' covariance of the predicted curve (rank the
number of parameters: Woodbury), V the test's noise (its fit's σ0², plus the discrepancy's
amplitude² under model error, on the diagonal: the process's correlation left out, which makes the
test stricter there): χ² on the test's points where the law is right, p < P_LAW fails. The
share of points inside the 90 % band is reported beside it.

It needs three temperatures at least (two to fit the law, one to hold out), and a held-out test
whose parameters are all shared (one with its own G or tau_max has nothing to be predicted from).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from bayes_dnlr.config import Config
from bayes_dnlr.errors import BayesDnlrError
from bayes_dnlr.inference.modulus_estimate import fit_source
from bayes_dnlr.runs.bands import N_CURVES, fit_noise, test_band
from bayes_dnlr.runs.modulus_block import analysis, at_temperature
from bayes_dnlr.runs.testset import TestSet

MIN_TEMPERATURES = 3
P_LAW = 0.01         # the held-out tests' χ² above its 99 % point: the law does not carry


def _temperatures(cfg: Config, tests: TestSet) -> dict[str, float]:
    return {t: at_temperature(cfg.for_test(t), d).value for t, d in tests.tests.items()}


def _mahalanobis(view: Config, data, columns: Mapping[str, np.ndarray], var: float) -> tuple[float, int]:
    """q = rᵀ(S + v I)⁻¹r of a test's data against the curves of the draws ``columns`` (r from their
    mean, S their covariance) and the noise variance ``var``; and the number of points."""
    from bayes_dnlr.inference.posterior.likelihood import build_model, window_rows

    model = build_model(view, data)
    rows = window_rows(data)
    n_draws = min(np.size(v) for v in columns.values())
    used = [k for k in model.parameter_names() + ["alpha"] if k in columns or k in view.fixed_values]
    curves = np.array([model.stress({k: float(np.atleast_1d(columns[k])[i]) if k in columns
                                     else float(view.fixed_values[k]) for k in used})[rows]
                       for i in range(n_draws)])
    y = np.asarray(data.stress[: data.model_end], dtype=float)[rows]
    r = y - curves.mean(axis=0)
    D = (curves - curves.mean(axis=0)) / np.sqrt(max(n_draws - 1, 1))      # S = DᵀD
    # (v I + DᵀD)⁻¹ = (I − Dᵀ(v I_k + D Dᵀ)⁻¹ D) / v
    inner = np.linalg.solve(var * np.eye(D.shape[0]) + D @ D.T, D @ r)
    q = float((r @ r - (D @ r) @ inner) / var)
    return q, int(r.size)


def leave_one_temperature_out(cfg: Config, tests: TestSet,
                              singles: Mapping[str, Mapping[str, Any]]) -> dict[str, Any] | None:
    """The ``shift_law`` of fit.json: per temperature held out, its tests' coverage by the band of the
    fit to the others ({temperature, tests: {name: {coverage, floor, points, ok}}, law: the
    others' estimate of the law's parameters}), ``ok`` over all, and ``note`` when it cannot be
    made. None without a temperature law."""
    from scipy.special import chdtrc  # the χ² survival function (scipy.stats costs seconds)

    from bayes_dnlr.inference.lsq.run_fit import fit_run

    s = cfg.model.shift
    if s.temperature == "none" or tests.plain:
        return None
    temps = _temperatures(cfg, tests)
    distinct = sorted({v for v in temps.values() if v is not None})
    if len(distinct) < MIN_TEMPERATURES:
        return {"ok": None, "held_out": [], "note": (
            f"the tests are at {len(distinct)} temperature(s): a law fitted to all but one needs "
            f"two, so {MIN_TEMPERATURES} are needed to hold one out; the law is not checked")}
    own = set(cfg.per_test_parameters)
    out = []
    for T in distinct:
        keep = [t for t in cfg.test_names if temps[t] != T]
        held = [t for t in cfg.test_names if temps[t] == T]
        entry: dict[str, Any] = {"temperature": T, "tests": {}}
        if own:
            entry["note"] = (f"the tests at {T:g} °C have their own {', '.join(sorted(own))}: nothing "
                             "to predict them from")
            out.append(entry)
            continue
        sub = cfg.model_copy(update={"tests": [x for x in cfg.tests if x.name in keep]})
        try:
            again = fit_run(sub, {t: tests.tests[t] for t in keep}, plain=False).to_dict()
        except BayesDnlrError as err:
            entry["note"] = f"the fit without {T:g} °C failed: {err}"
            out.append(entry)
            continue
        estimate_, cov, names, under = analysis(again)
        entry["law"] = {k: estimate_[k] for k in s.parameters if k in estimate_}
        draws = fit_source(estimate_, cov, names, sub.fixed_values, bool(again.get("converged", True)),
                           under)
        for t in held:
            view = cfg.for_test(t)
            columns = {k: draws.draws[k][:N_CURVES] for k in view.parameters if k in draws.draws}
            unseen = [k for k in view.parameters if k not in columns and k not in view.fixed_values]
            if unseen:
                entry.setdefault("note", f"{t} has {', '.join(unseen)}, which the tests at the other "
                                         "temperatures do not measure: nothing to predict it from")
                continue
            noise = fit_noise(view, tests.tests[t], singles.get(t) or {}, under)
            band = test_band(view, tests.tests[t], columns, noise)
            q, n = _mahalanobis(view, tests.tests[t], columns, noise.var)
            p = float(chdtrc(n, q))
            entry["tests"][t] = {"coverage": float(np.mean(band.inside)), "chi2": q, "points": n,
                                 "p": p, "ok": p >= P_LAW}
        out.append(entry)
    checked = [e for e in out if e["tests"]]
    ok = all(x["ok"] for e in checked for x in e["tests"].values()) if checked else None
    return {"ok": ok, "held_out": out}

