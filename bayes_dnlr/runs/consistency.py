"""The ``consistency`` block of summary.json for a run with several tests: does each test, fitted
alone, give the E(t) and the E the others give? (inference/analyses/agreement.py, the package's one
test of agreement: Cochran's Q over the tests' own estimates at the level P_AGREE, the pair furthest
apart in combined sd.)

Each test's own E(t) is the one estimator's on its fit (fit.json ``single_fits``, runs/modulus_block.py
``fit_rows``: the generalized analysis when that test shows model error, else the white one, with
the spectrum exponent's spread), at times every test resolves (``output.modulus_at``, else the
longest of the tests' default times) when the tests share the spectrum (tau_max and alpha not
``per: test``); E always, with its linearized sd.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from bayes_dnlr.config import Config
from bayes_dnlr.inference.analyses.agreement import Agreement, agreement
from bayes_dnlr.inference.modulus_window import default_times, test_window
from bayes_dnlr.numbers import fmt, pm
from bayes_dnlr.runs.modulus_block import analysis, fit_rows
from bayes_dnlr.runs.testset import TestSet


def _own_e(single: Mapping[str, Any]) -> tuple[float, float, str] | None:
    """A test's own E and its linearized sd: generalized under model error, else white."""
    est, cov, names, under = analysis(single)
    if "E" not in names or cov is None or "E" not in est:
        return None
    j = names.index("E")
    return float(est["E"]), float(np.sqrt(cov[j, j])), "generalized" if under else "white"


def common_times(cfg: Config, tests: TestSet) -> list[float]:
    """Times every test resolves: output.modulus_at, else the longest of the default times."""
    if cfg.output.modulus_at:
        return list(cfg.output.modulus_at)
    return [max(default_times(test_window(data))[0][0] for data in tests.tests.values())]


def reduced_times(cfg: Config, tests: TestSet, fit: Mapping[str, Any]
                  ) -> tuple[list[float], dict[str, float], str | None]:
    """With a temperature law and tests at several temperatures: times at the reference temperature
    that every test resolves in reduced time (its times over a_T at the joint fit's law), each
    test's a_T, and why E(t) is not compared when their reduced windows do not overlap. Without:
    ``common_times`` and a_T = 1."""
    from bayes_dnlr.inference.modulus_window import nice_time
    from bayes_dnlr.runs.modulus_block import at_temperature

    s = cfg.model.shift
    ats = {t: at_temperature(cfg.for_test(t), data) for t, data in tests.tests.items()}
    if s.temperature == "none" or len({a.value for a in ats.values()}) < 2:
        return common_times(cfg, tests), dict.fromkeys(tests.tests, 1.0), None
    joint = analysis(fit)[0]
    factor = {t: float(a.factor({**cfg.fixed_values, **joint})) for t, a in ats.items()}
    lo = max(test_window(d).shortest / factor[t] for t, d in tests.tests.items())
    hi = min(test_window(d).longest / factor[t] for t, d in tests.tests.items())
    if cfg.output.modulus_at:
        return list(cfg.output.modulus_at), factor, None
    if lo > hi:
        return [], factor, (f"E(t) not compared: the tests' windows in reduced time at "
                            f"{s.reference_temperature:g} °C do not overlap (their temperatures "
                            "are too far apart for one time every test resolves)")
    t = nice_time(lo)
    return [t if t <= hi else lo], factor, None


def consistency(cfg: Config, tests: TestSet, fit: Mapping[str, Any]) -> dict[str, Any] | None:
    """The block: per quantity the tests' own values, Cochran's Q and whether they agree; ``agree``
    over all; ``words`` for a person. None for a run with one test or without single fits."""
    singles = fit.get("single_fits") or {}
    if len(singles) < 2:
        return None
    # E(t) is one material function only where the tests share the spectrum; with a tau_max (or
    # an alpha) per test, the run itself says their E(t) differ, and only E is compared
    shared_spectrum = not ({"tau_max", "alpha"} & set(cfg.per_test_parameters))
    times, factor, note = reduced_times(cfg, tests, fit) if shared_spectrum else ([], {}, None)
    at_ref = (f" at {cfg.model.shift.reference_temperature:g} °C"
              if any(a != 1.0 for a in factor.values()) else "")
    values: dict[str, dict[str, float]] = {}
    sds: dict[str, dict[str, float]] = {}
    how = {}
    for t, single in singles.items():
        if t not in tests.tests or not single.get("estimate"):
            continue
        own = _own_e(single)
        if own is not None:
            values.setdefault("E", {})[t], sds.setdefault("E", {})[t], how[t] = own
        own_times = [x * factor.get(t, 1.0) for x in times]
        found = fit_rows(cfg.for_test(t), tests.tests[t], single, f"{t}: ", own_times) if times else None
        for x, row in zip(times, found.rows if found is not None else [], strict=False):
            key = f"E({fmt(x, 3)} s){at_ref}"
            values.setdefault(key, {})[t] = row["mean"]
            sds.setdefault(key, {})[t] = row["sd"]
    found = [a for k in values if (a := agreement(k, values[k], sds[k])) is not None]
    if not found:
        return None
    # the tests agree when their E(t), what the data determine, agree; E, the extrapolation through
    # the spectrum's fast end, decides only where E(t) cannot be compared (a spectrum per test)
    deciding = [a for a in found if a.quantity != "E"] or found
    text = words(found, deciding)
    return {"times": times, "estimates": how, "quantities": [a.to_dict() for a in found],
            "decided_by": [a.quantity for a in deciding], "shift_factors": factor,
            "agree": all(a.agree for a in deciding),
            "words": text + (f" ({note}.)" if note else "")}


def words(found: list[Agreement], deciding: list[Agreement]) -> str:
    """One sentence per quantity whose tests disagree, else that they agree (and a note when only
    E, not deciding, differs)."""
    bad = [a for a in deciding if not a.agree]
    if not bad:
        text = ("Fitted alone, the tests agree: " + "; ".join(
            f"{a.quantity} within {a.worst_z:.1f} combined sd" for a in deciding) + ".")
        other = [a for a in found if a not in deciding and not a.agree]
        for a in other:
            i, j = a.worst_pair
            text += (f" Their E differ ({i} {pm(a.values[i], a.sds[i])}, {j} "
                     f"{pm(a.values[j], a.sds[j])} MPa, {a.worst_z:.1f} combined sd): E extrapolates "
                     "through the spectrum's fast end, which each kind of test reaches differently; "
                     "quote E(t).")
        return text
    out = []
    for a in bad:
        i, j = a.worst_pair
        out.append(f"{a.quantity}: {i} gives {pm(a.values[i], a.sds[i])} MPa and {j} "
                   f"{pm(a.values[j], a.sds[j])} MPa, {a.worst_z:.1f} combined sd apart (Cochran's Q "
                   f"{a.q:.1f} on {a.df} df, p = {a.p:.2g})")
    return ("Fitted alone, the tests do not agree, so a shared value over them is not one "
            "material's: " + "; ".join(out) + ". Look at what differs between them (material, "
            "temperature, a test the model does not describe) before quoting the joint value.")
