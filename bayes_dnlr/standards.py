"""Moduli of the tensile standards on a nominal stress-strain curve (paper section 2.4, Tables 1 and 4).

Both standards work on the *nominal* curve: engineering strain e = ΔL/L0 and nominal stress F/S0.
They measure an apparent modulus at a finite strain rate, which for a viscoelastic polymer is far
below the instantaneous modulus E of the DNLR model (the paper: 1138 MPa against 2830 MPa).

ISO 527-1 (tensile modulus E_t)
    The standard defines E_t between the nominal strains e1 = 0.05 % and e2 = 0.25 %, either as the
    chord (σ2 - σ1)/(e2 - e1) or, with computer-aided equipment, as the least-squares slope of the
    curve between those two strains. We use the **least-squares slope** whenever the range holds at
    least ``min_points`` samples: on a sampled, noisy record it uses every sample instead of two
    interpolated ones (the chord's scatter is about sqrt(n/6) times larger for n evenly spread samples
    with the same noise). With fewer samples we fall back on the chord, interpolating the stress
    linearly at e1 and e2 on the first passage of the curve through them. ISO 527-1 has no toe
    compensation: it asks for a small prestress instead, so the strains are taken as recorded.

ASTM D638 (modulus of elasticity, with the toe compensation of its Annex A1)
    The modulus is the slope of the initial linear portion; a toe region (slack, seating) is removed
    by extending that straight line to zero stress, which gives the corrected zero strain (A1.2);
    a curve with no linear region uses the tangent of maximum slope at the inflection point (A1.3).
    Our rule, which covers both cases: slide a window of consecutive samples spanning ``width`` of
    nominal strain (default 0.25 %, the ISO span; at least ``min_points`` = 5 samples, more strain
    when the record is sparse) in steps of half a window over the rising part of the curve (from the
    first sample to the one where the nominal stress first reaches ``search_fraction`` = 50 % of its
    maximum), fit a least-squares line in each window and keep the **steepest** one. Its slope is
    the modulus; its zero-stress intercept is the corrected zero.
    For a concave viscoelastic curve with no toe (HDPE) the steepest window is the first one, so the
    ASTM and ISO values come out close, as in the paper's Table 1. With noisy data the maximum over
    windows is biased upwards by about one standard error of a window slope (half-overlapping
    windows keep the number of candidates small).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

ISO_STRAINS = (0.0005, 0.0025)   # nominal strains of ISO 527-1, 0.05 % and 0.25 %


@dataclass(frozen=True)
class StandardModulus:
    """One standard modulus and how it was obtained (``modulus`` is None with a ``reason``)."""

    standard: str                      # "ISO 527-1" | "ASTM D638"
    modulus: float | None              # MPa
    method: str                        # regression | chord | steepest window (toe-compensated)
    strain_range: tuple[float, float] | None = None  # nominal strains used (as recorded)
    n_points: int = 0                  # samples in the fit
    corrected_zero: float = 0.0        # nominal strain of the corrected zero (ASTM A1.2)
    reason: str | None = None          # why modulus is None, or a note on the method

    def describe(self) -> str:
        """One line for a report."""
        if self.modulus is None:
            return f"{self.standard}: not available ({self.reason})"
        lo, hi = self.strain_range or (float("nan"), float("nan"))
        text = (f"{self.standard}: {self.modulus:.0f} MPa, {self.method} over nominal strain "
                f"{100 * lo:.3f}-{100 * hi:.3f} % ({self.n_points} samples)")
        if self.standard == "ASTM D638":
            text += f", corrected zero at {100 * self.corrected_zero:.4f} %"
        if self.reason:
            text += f"; {self.reason}"
        return text


def _clean(strain: np.ndarray, stress: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    e = np.asarray(strain, dtype=float)
    s = np.asarray(stress, dtype=float)
    if e.shape != s.shape or e.ndim != 1:
        raise ValueError(f"strain and stress must be 1-D arrays of one length, got {e.shape}, {s.shape}")
    ok = np.isfinite(e) & np.isfinite(s)
    return e[ok], s[ok]


def _slope(e: np.ndarray, s: np.ndarray) -> tuple[float, float]:
    """Least-squares line s = a + b e: returns (b, a)."""
    em = e.mean()
    de = e - em
    b = float(np.dot(de, s - s.mean()) / np.dot(de, de))
    return b, float(s.mean() - b * em)


def _first_crossing(e: np.ndarray, s: np.ndarray, level: float) -> float | None:
    """Stress where the curve first reaches ``level`` of strain (linear interpolation)."""
    above = np.flatnonzero(e >= level)
    if above.size == 0:
        return None
    i = int(above[0])
    if i == 0:
        return float(s[0]) if e[0] == level else None
    e0, e1, s0, s1 = e[i - 1], e[i], s[i - 1], s[i]
    return float(s0 + (s1 - s0) * (level - e0) / (e1 - e0))


def iso527_1_modulus(nominal_strain: np.ndarray, nominal_stress: np.ndarray,
                     strains: tuple[float, float] = ISO_STRAINS, method: str = "auto",
                     min_points: int = 5) -> StandardModulus:
    """ISO 527-1 tensile modulus E_t (MPa) between nominal strains 0.05 % and 0.25 % (section 2.4).

    method: ``regression`` (least-squares slope over the range), ``chord`` (two interpolated
    points) or ``auto`` (regression with at least ``min_points`` samples in the range, else chord).
    Only the first passage of the loading curve through the range is used (samples before the
    strain first exceeds twice e2).
    """
    e, s = _clean(nominal_strain, nominal_stress)
    e1, e2 = strains
    name = "ISO 527-1"
    if not 0 <= e1 < e2:
        raise ValueError(f"strains must satisfy 0 <= e1 < e2, got {strains}")
    if method not in ("auto", "regression", "chord"):
        raise ValueError(f"method must be auto, regression or chord, got {method!r}")
    if e.size < 2:
        return StandardModulus(name, None, method, reason="fewer than two samples")
    if e.max() < e2:
        return StandardModulus(name, None, method, reason=(
            f"the curve does not reach {100 * e2:.2f} % nominal strain (max {100 * e.max():.3f} %)"))
    if e[0] > e1:
        return StandardModulus(name, None, method, reason=(
            f"the curve starts above {100 * e1:.2f} % nominal strain ({100 * e[0]:.3f} %)"))
    past = np.flatnonzero(e > 2 * e2)
    end = int(past[0]) if past.size else e.size
    e, s = e[:end], s[:end]
    inside = (e >= e1) & (e <= e2)
    n = int(inside.sum())
    use = method
    if method == "auto":
        use = "regression" if n >= min_points else "chord"
    if use == "regression":
        if n < 2:
            return StandardModulus(name, None, use, reason=f"{n} sample(s) between the two strains")
        b, _ = _slope(e[inside], s[inside])
        note = None
        if n < min_points:
            note = f"only {n} samples in the range"
        return StandardModulus(name, b, "least-squares slope", (e1, e2), n, reason=note)
    s1, s2 = _first_crossing(e, s, e1), _first_crossing(e, s, e2)
    if s1 is None or s2 is None:  # pragma: no cover - excluded by the checks above
        return StandardModulus(name, None, "chord", reason="the curve does not cross both strains")
    note = (f"only {n} sample(s) between the two strains, fewer than the {min_points} a least-squares "
            "slope needs" if method == "auto" else None)
    return StandardModulus(name, (s2 - s1) / (e2 - e1), "chord", (e1, e2), 2, reason=note)


def astm_d638_modulus(nominal_strain: np.ndarray, nominal_stress: np.ndarray, width: float = 0.0025,
                      search_fraction: float = 0.5, min_points: int = 5) -> StandardModulus:
    """ASTM D638 modulus of elasticity (MPa) with the toe compensation of its Annex A1.

    The steepest least-squares line over half-overlapping windows of consecutive samples spanning
    ``width`` of nominal strain (at least ``min_points`` samples) on the rising part of the curve
    (up to ``search_fraction`` of the maximum stress); its zero-stress intercept is the corrected
    zero strain (A1.2, A1.3).
    """
    e, s = _clean(nominal_strain, nominal_stress)
    name = "ASTM D638"
    method = "steepest window (toe-compensated)"
    if e.size < min_points:
        return StandardModulus(name, None, method, reason=f"fewer than {min_points} samples")
    if not 0 < search_fraction <= 1:
        raise ValueError(f"search_fraction must be in (0, 1], got {search_fraction}")
    smax = float(np.max(s))
    if not smax > 0:
        return StandardModulus(name, None, method, reason="the nominal stress never becomes positive")
    end = int(np.flatnonzero(s >= search_fraction * smax)[0]) + 1
    end = max(end, min(min_points, e.size))
    e, s = e[:end], s[:end]
    if float(e.max() - e.min()) <= 0:
        return StandardModulus(name, None, method, reason="no strain increase before the search limit")
    w = float(width)
    best: tuple[float, float, int, int] | None = None   # slope, intercept, first, last (inclusive)
    i = 0
    while i + min_points <= e.size:
        # the window: samples i..j in test order, spanning `width` of strain, at least min_points
        over = np.flatnonzero(e[i:] > e[i] + w)
        j = i + int(over[0]) - 1 if over.size else e.size - 1
        j = max(j, i + min_points - 1)
        b, a = _slope(e[i:j + 1], s[i:j + 1])
        if best is None or b > best[0]:
            best = (b, a, i, j)
        if j >= e.size - 1:
            break
        # half-overlapping windows: the next one starts half a window further on
        nxt = np.flatnonzero(e[i + 1:] >= e[i] + w / 2)
        i = max(i + 1, min(i + 1 + int(nxt[0]) if nxt.size else e.size, i + (j - i + 1) // 2))
    if best is None or not best[0] > 0:
        return StandardModulus(name, None, method, reason=(
            f"no window of {min_points} samples with a positive slope "
            f"before {100 * search_fraction:.0f} % of the maximum stress"))
    b, a, i, j = best
    return StandardModulus(name, b, method, (float(e[i]), float(e[j])), j - i + 1, corrected_zero=-a / b)


def nominal_curve(test) -> tuple[np.ndarray, np.ndarray, str | None]:
    """The loading part of a test's nominal curve: (e, F/S0, note).

    Uses ``test.nominal_stress`` when the data give a force; otherwise derives F/S0 = σ*·exp(-ε)
    from the observable under the isovolumic assumption (eq. 6), and says so in the note.
    Samples after ``relaxation_start`` are dropped, and so are the model-only samples the reader
    puts before the first measured one (``virtual_start``: an unloaded origin for a cropped toe):
    a standard is computed on measured samples only, never on a point the package made.
    """
    first = int(getattr(test, "virtual_start", 0))
    e = np.asarray(test.nominal_strain, dtype=float)
    note = None
    if test.nominal_stress is not None:
        s = np.asarray(test.nominal_stress, dtype=float)
    else:
        s = np.asarray(test.stress, dtype=float) * np.exp(-np.asarray(test.strain, dtype=float))
        note = "nominal stress derived from the true stress as σ·exp(-ε) (isovolumic, eq. 6)"
    keep = np.arange(e.size) >= first
    if test.relaxation_start is not None:
        keep &= np.asarray(test.time) <= test.relaxation_start
    return e[keep], s[keep], note


def standard_results(test) -> dict[str, StandardModulus]:
    """Both standard moduli of a ``TestData`` with their details (for the report)."""
    e, s, note = nominal_curve(test)
    out = {"iso527_1": iso527_1_modulus(e, s), "astm_d638": astm_d638_modulus(e, s)}
    if note:
        out = {k: _with_note(v, note) for k, v in out.items()}
    return out


def _with_note(r: StandardModulus, note: str) -> StandardModulus:
    from dataclasses import replace

    if r.modulus is None:
        return r
    return replace(r, reason=f"{r.reason}; {note}" if r.reason else note)


def standard_moduli(test) -> dict[str, float | None]:
    """{"iso527_1": MPa | None, "astm_d638": MPa | None} of a ``TestData`` (summary.json ``standards``).

    None when the curve does not cover what the standard needs; ``standard_results`` gives the reason.
    """
    return {k: (None if r.modulus is None else float(r.modulus))
            for k, r in standard_results(test).items()}
