"""Checks of the read columns: increasing time, plausible strains (eq. 1), units that look wrong,
and the state of the specimen at the first sample."""

from __future__ import annotations

import numpy as np

from bayes_dnlr.data.conversions import hencky_from_nominal
from bayes_dnlr.data.errors import DataError
from bayes_dnlr.data.reading import Table

MAX_HENCKY = 5.0          # λ = e^5 ≈ 148: larger axial strains are taken for a unit mistake (percent)
MIN_POLYMER_MODULUS = 100.0   # MPa: an initial slope below this, in a semicrystalline polymer, is a unit slip
FIRST_SAMPLE_NOISE = 10.0     # a first stress this many noise sd away from zero is a loaded start
LOADED_START = "the first sample"   # how the warning of a loaded start begins (init looks for it)


def check_increasing(table: Table, x: np.ndarray, role: str, what: str) -> None:
    """x must increase strictly; the error gives both lines and both cells."""
    bad = np.flatnonzero(np.diff(x) <= 0)
    if bad.size:
        i = int(bad[0])
        a, b = table.cell(i, role), table.cell(i + 1, role)
        raise DataError(f"{table.path}, column '{table.names[role]}': {what}: line {table.lines[i]} "
                        f"has {a} and line {table.lines[i + 1]} has {b}")


def _looks_like_time(x: np.ndarray) -> bool:
    """Increasing in nearly even steps, from about zero: what a time or index column looks like."""
    d = np.diff(x)
    return bool(x.size >= 5 and np.all(d > 0) and np.std(d) < 0.05 * np.mean(d) and x[0] >= 0)


def implausible_strain(table: Table, role: str, raw: np.ndarray, strain: np.ndarray,
                       measure: str, percent_known: bool) -> None:
    """Refuse an axial Hencky strain above MAX_HENCKY, with a hint that fits the column."""
    big = np.flatnonzero(np.abs(strain) > MAX_HENCKY)
    if not big.size:
        return
    i = int(big[0])
    head = (f"{table.where(i, role)}: strain {table.cell(i, role)} is not a plausible strain "
            f"(Hencky {strain[i]:.3g})")
    as_percent = raw / 100.0
    percent_ok = bool(np.all(np.abs(hencky_from_nominal(as_percent) if measure == "nominal" else as_percent)
                             <= MAX_HENCKY)) and not percent_known
    if _looks_like_time(raw):
        raise DataError(f"{head}: the column rises in even steps from {raw[0]:g} to {raw[-1]:g}, like a time "
                        f"or index column: is data.columns.{role} the right column (a header that does not "
                        f"line up with the data, or a wrong column number)?")
    if percent_ok:
        raise DataError(f"{head}: percent? set data.strain_unit: percent")
    raise DataError(f"{head}: even read as percent it is too large: is data.columns.{role} the right "
                    f"column?")


def to_hencky(table: Table, raw: np.ndarray, role: str, measure: str) -> np.ndarray:
    """Hencky strain from a strain column given as ``measure`` (eq. 1)."""
    if measure == "hencky":
        return raw
    bad = np.flatnonzero(raw <= -1.0)
    if bad.size:
        i = int(bad[0])
        raise DataError(f"{table.where(i, role)}: nominal strain {table.cell(i, role)} <= -1 "
                        f"has no Hencky strain (eq. 1: ε = ln(1 + e))")
    return hencky_from_nominal(raw)


def noise_sd(x: np.ndarray) -> float:
    """Robust sd of white noise on a smooth signal: MAD of second differences (trend-free)."""
    if x.size < 5:
        return float("nan")
    d2 = np.diff(x, 2)
    mad = np.median(np.abs(d2 - np.median(d2)))
    return float(1.4826 * mad / np.sqrt(6.0))


def initial_slope(strain: np.ndarray, stress: np.ndarray) -> tuple[float, int, int]:
    """Steepest least-squares slope dσ/dε over a sliding window on the rising part below half the
    stress maximum (the tangent at maximum slope of ASTM D638 X1.3); (slope, first, last index)."""
    n = strain.size
    top = int(np.argmax(stress))
    rise = np.flatnonzero(stress[:top + 1] <= stress[0] + 0.5 * (stress[top] - stress[0]))
    end = int(rise[-1]) + 1 if rise.size else min(n, 10)
    end = max(end, min(n, 10))
    w = max(5, end // 10)
    if end < w:
        return float("nan"), 0, end
    x, y = strain[:end], stress[:end]
    c = np.concatenate(([0.0], np.cumsum(x)))
    cy = np.concatenate(([0.0], np.cumsum(y)))
    cxx = np.concatenate(([0.0], np.cumsum(x * x)))
    cxy = np.concatenate(([0.0], np.cumsum(x * y)))
    k = np.arange(end - w + 1)
    sx, sy = c[k + w] - c[k], cy[k + w] - cy[k]
    sxx, sxy = cxx[k + w] - cxx[k], cxy[k + w] - cxy[k]
    den = sxx - sx * sx / w
    slope = np.where(den > 0, (sxy - sx * sy / w) / np.where(den > 0, den, 1.0), -np.inf)
    j = int(np.argmax(slope))
    return float(slope[j]), j, j + w


def percent_warning(nominal_strain: np.ndarray, nominal_stress: np.ndarray | None, name: str) -> str | None:
    """A note when the strain's magnitude does not fit the stress: an initial slope below any
    semicrystalline polymer's modulus suggests a percent column read as a fraction."""
    if nominal_stress is None or nominal_strain.size < 10:
        return None
    slope, a, b = initial_slope(nominal_strain, nominal_stress)
    top = float(np.max(nominal_strain))
    if not np.isfinite(slope) or slope <= 0 or slope >= MIN_POLYMER_MODULUS or top < 0.05:
        return None
    return (f"warning: the initial slope of the nominal stress-strain curve is {slope:.3g} MPa (strain "
            f"up to {top:.3g}), below the modulus of any semicrystalline polymer (>= "
            f"{MIN_POLYMER_MODULUS:g} MPa): if the strain column '{name}' is in percent, set "
            f"data.strain_unit: percent (x100 gives {100 * slope:.4g} MPa); if it is a fraction, "
            f"set data.strain_unit: fraction to silence this")


def first_sample_warning(stress: np.ndarray, strain: np.ndarray, line: int,
                         force: np.ndarray | None = None, area0: float | None = None) -> str | None:
    """A note when the first sample carries a load well above the noise: the model assumes the
    specimen unloaded and at rest there. With a force column the load is said in
    newtons first: a stress in MPa is only as right as area0, and without area0 (``None``: init's
    placeholder) it is not said at all."""
    load, unit = (stress, "MPa") if force is None else (force, "N")
    sd = noise_sd(load[:200])
    scale = float(np.max(np.abs(load)))
    limit = max(FIRST_SAMPLE_NOISE * sd, 0.01 * scale)
    if not abs(load[0]) > limit:
        return None
    what = f"{load[0]:.4g} {unit}"
    if force is not None:
        share = f"{100 * abs(load[0]) / scale:.2g} % of the peak force"
        what += (f" ({stress[0]:.4g} MPa with area0 = {area0:g} mm², {share})" if area0 is not None
                 else f" ({share})")
    return (f"warning: {LOADED_START} (line {line}) carries {what} at strain {strain[0]:.4g} "
            f"({'force' if force is not None else 'stress'} noise sd about {sd:.2g} {unit}): the model "
            f"assumes the specimen unloaded and at rest there, so the toe looks cropped or preloaded and "
            f"E will be biased; set data.toe: compensate (ASTM D638 X1, ISO 527-1 zero point) or "
            f"data.initial_state: ramp-from-zero (docs/data-input.md, 'The first sample')")


def spike_warning(stress: np.ndarray, lines: np.ndarray, start: int = 0,
                  strain: np.ndarray | None = None, window: np.ndarray | None = None) -> str | None:
    """A note on the largest isolated spike of the stress: a sample far from both neighbours (more
    than 50 noise sd and 5 % of the stress range away from their mean), such as one force cell
    written ×1000; it would dominate a least-squares fit. A sample where the strain turns as well
    (the peak or the valley of a loading-unloading cycle, the start of an unloading or of a hold,
    sparsely sampled) is the test's history, not a spike: the strain's own excursion from its
    neighbours' mean, relative to its range, is at least a quarter of the stress's, on the same side.
    A fall that the stress never climbs back from is the specimen breaking, not a spike: a note, a
    warning only when it lies inside the fit's ``window`` (a mask of the samples)."""
    s = stress[start:]
    if s.size < 5:
        return None
    dev = s[1:-1] - 0.5 * (s[:-2] + s[2:])
    sd = noise_sd(s)
    spread = float(np.max(s) - np.min(s))
    big = (np.abs(dev) > 50 * max(sd, 1e-12)) & (np.abs(dev) > 0.05 * spread)
    if strain is not None and big.any():
        e = strain[start:]
        de = e[1:-1] - 0.5 * (e[:-2] + e[2:])
        span = float(np.max(e) - np.min(e))
        if span > 0:
            turning = (np.sign(de) == np.sign(dev)) & (np.abs(de) / span >= 0.25 * np.abs(dev) / spread)
            big &= ~turning
    if not big.any():
        return None
    i = int(np.argmax(np.where(big, np.abs(dev), -np.inf)))
    k = start + i + 1
    before, after = stress[k - 1], stress[k + 1:]
    fall = before - after[0]        # a spike's neighbours agree; a break falls across the sample
    if fall > abs(dev[i]) and np.max(after) < before - 0.5 * fall:
        inside = window is not None and bool(np.any(window[k + 1:]))
        where = ("inside the window: the model has no break; end data.window before it" if inside else
                 "after the window: the fit does not use it")
        return (f"{'warning: ' if inside else ''}the specimen breaks at line {lines[k + 1]}: the stress "
                f"falls from {stress[k]:.6g} to {stress[k + 1]:.6g} MPa and does not climb back, "
                f"{where}")
    return (f"warning: a spike at line {lines[k]}: the stress there is {stress[k]:.6g} MPa, its neighbours "
            f"{stress[k - 1]:.6g} and {stress[k + 1]:.6g} MPa (stress noise sd about {sd:.2g} MPa), while "
            f"the strain does not turn there: a corrupt cell? It would dominate the fit")


NO_LOAD_NOISE = 10.0      # a peak stress within this many noise sd of zero is no load


def check_load(stress: np.ndarray, window: np.ndarray, lines: np.ndarray, path, source: str) -> None:
    """Refuse a test without tensile load in its window: a stress that never rises clearly above
    zero (a force column of zeros, a compressive sign, a wrong column, an area0 far too large)
    cannot identify E; the least squares would only report a singular sensitivity matrix."""
    s = stress[window]
    if s.size == 0:
        return
    peak = float(np.max(s))
    sd = noise_sd(s)
    sd = sd if np.isfinite(sd) else 0.0     # fewer than 5 samples: no noise estimate
    if peak > 0 and peak > NO_LOAD_NOISE * sd:
        return
    rows = lines[window]
    first = int(rows[rows > 0].min(initial=int(rows.max())))
    raise DataError(f"{path}: no tensile load in data.window (lines {first}-{int(rows.max())}): the "
                    f"stress is at most {peak:.4g} MPa (noise sd about {sd:.2g} MPa). Tension must be "
                    f"positive: {source} is zero, has the compressive sign (negate it), or is the wrong "
                    f"column; or area0 is far too large")
