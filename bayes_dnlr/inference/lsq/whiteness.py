"""Is the residual white? (paper 3.2 after eq. 36, and 4.1)

Without model bias the residuals are the noise: "unsigned", no long excursions on one side of zero.
The paper reads their sign structure by eye; here three standard statistics do it:
lag-1 autocorrelation r1, the Durbin-Watson statistic d ≈ 2(1 - r1), and the Wald-Wolfowitz runs test
on the signs. Residuals are called white when r1 is within the 99 % band of white noise
(|r1| √n < 2.576) and the runs test does not reject at 1 %.
"""

from __future__ import annotations

import math
from statistics import NormalDist

import numpy as np

ALPHA = 0.01


def lag1_autocorrelation(e: np.ndarray) -> float:
    """r1 = Σ (e_i - ē)(e_{i+1} - ē) / Σ (e_i - ē)²."""
    d = np.asarray(e, dtype=float) - np.mean(e)
    den = float(d @ d)
    return float(d[:-1] @ d[1:] / den) if den > 0 else 0.0


def durbin_watson(e: np.ndarray) -> float:
    """d = Σ (e_i - e_{i-1})² / Σ e_i²: 2 for white noise, → 0 for slowly wandering residuals."""
    e = np.asarray(e, dtype=float)
    den = float(e @ e)
    return float(np.sum(np.diff(e) ** 2) / den) if den > 0 else 2.0


def runs_test(e: np.ndarray) -> dict[str, float]:
    """Wald-Wolfowitz runs test on the signs of the residuals (zeros dropped), two-sided.

    Returns n_runs, expected (2 n+ n- / n + 1), z and p_value. Too few runs means signed residuals.
    """
    s = np.sign(np.asarray(e, dtype=float))
    s = s[s != 0]
    n_pos, n_neg = int(np.sum(s > 0)), int(np.sum(s < 0))
    n = n_pos + n_neg
    runs = int(1 + np.count_nonzero(s[1:] != s[:-1])) if n else 0
    if n_pos == 0 or n_neg == 0:
        return {"n_runs": runs, "expected": float(runs), "z": -math.inf, "p_value": 0.0}
    mu = 2.0 * n_pos * n_neg / n + 1.0
    var = (mu - 1.0) * (mu - 2.0) / (n - 1.0)
    z = (runs - mu) / math.sqrt(var) if var > 0 else 0.0
    return {"n_runs": runs, "expected": mu, "z": z, "p_value": math.erfc(abs(z) / math.sqrt(2.0))}


def _not_white(r1: float, dw: float, runs: dict[str, float], n: int, z_crit: float) -> str:
    """The verdict on residuals that are not white, in the words of the statistics that say so: the
    residuals are called signed only when the lag-1 autocorrelation or Durbin-Watson shows that
    neighbours share their sign; the runs test alone (r1 and d those of white noise) is a structure
    in the signs that the largest residuals do not carry."""
    band = z_crit / math.sqrt(max(n, 1))            # white noise: |r1| < band, |d - 2| < 2 band
    counts = (f"lag-1 autocorrelation {r1:+.3f}, Durbin-Watson {dw:.2f}, {runs['n_runs']} runs for "
              f"{runs['expected']:.0f} expected")
    if r1 > band or dw < 2 - 2 * band:
        mean_run = n / max(runs["n_runs"], 1)
        return (f"NOT white: the residuals are signed ({counts}, mean run {mean_run:.1f} samples). The "
                "model does not follow the data to within the noise: model bias, as the paper reads "
                "such residuals (4.1); the linearized sd understate the real uncertainty")
    if r1 < -band or dw > 2 + 2 * band:
        return (f"NOT white: neighbouring residuals alternate in sign ({counts}): not the independent "
                "noise the least squares assume (a filtered or resampled signal, or an oscillation); "
                "the linearized sd are not reliable")
    how = "form longer runs" if runs["n_runs"] < runs["expected"] else "alternate more often"
    return (f"NOT white by the runs test alone: the signs {how} than noise's ({runs['n_runs']} runs "
            f"for {runs['expected']:.0f} expected, p = "
            f"{runs['p_value']:.2g}), while the lag-1 autocorrelation ({r1:+.3f}) and Durbin-Watson "
            f"({dw:.2f}) are those of white noise: the sign pattern sits in the small residuals, which "
            "the large ones outweigh (a slow drift below the noise, or residuals of very unequal size); "
            "read the residual plot before trusting the linearized sd")


def residual_diagnostics(e: np.ndarray, sigma0: float | None = None,
                         sigma0_source: str | None = None) -> dict:
    """rms, r1, Durbin-Watson, runs test, white (bool) and a verdict in words."""
    e = np.asarray(e, dtype=float)
    n = e.size
    rms = float(np.sqrt(np.mean(e**2))) if n else 0.0
    r1 = lag1_autocorrelation(e)
    dw = durbin_watson(e)
    runs = runs_test(e)
    z_crit = NormalDist().inv_cdf(1.0 - ALPHA / 2)   # scipy.stats costs 0.4 s to import
    r1_ok = abs(r1) * math.sqrt(max(n, 1)) < z_crit
    runs_ok = runs["p_value"] >= ALPHA
    white = bool(r1_ok and runs_ok)
    if white:
        verdict = (f"white: no sign structure (lag-1 autocorrelation {r1:+.3f}, {runs['n_runs']} runs "
                   f"for {runs['expected']:.0f} expected); the residuals look like noise")
    else:
        verdict = _not_white(r1, dw, runs, n, z_crit)
    if sigma0_source == "whitened" and sigma0 is not None and sigma0 > 0:
        ratio = rms / sigma0                # L⁻¹e has no unit: 1 under the modelled noise
        if ratio > 1.5 or ratio < 1 / 1.5:
            verdict += (f". The rms of the whitened residuals ({rms:.3g}, no unit) is {ratio:.2g}x the "
                        f"{sigma0:g} they have when the model of the noise holds")
    elif sigma0 is not None and sigma0_source not in (None, "residuals") and sigma0 > 0:
        ratio = rms / sigma0
        if ratio > 1.5:
            verdict += (f". The rms residual ({rms:.3g} MPa) is {ratio:.1f}x sigma0 "
                        f"({sigma0:.3g} MPa, {sigma0_source})")
        elif ratio < 1 / 1.5:
            verdict += (f". The rms residual ({rms:.3g} MPa) is well below sigma0 "
                        f"({sigma0:.3g} MPa, {sigma0_source}): sigma0 may be overstated")
    return {"rms": rms, "lag1_autocorrelation": r1, "durbin_watson": dw, "runs_test": runs,
            "white": white, "verdict": verdict}
