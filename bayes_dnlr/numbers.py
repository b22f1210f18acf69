"""Numbers as people read them: significant digits, a value to the precision of its sd, percents.

The one precision rule of the package, used by the console tables, the report's headline
and tables, compare and batch, so that one value reads the same everywhere:

- a value without an sd: ``SIG`` = 4 significant digits (``fmt``);
- an sd: ``SD_DIGITS`` = 2 significant digits, integer digits never rounded away (``fmt_sd``:
  13.77 -> 14, 0.000613 -> 0.00061, 137.7 -> 138);
- a value with its sd: the value to the decimals of its two-digit sd, and at least 4 significant
  digits (``fmt_at``), written ``value ± sd`` (``pm``); interval ends at the decimals of the sd of
  the value they bound (``interval``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

SIG = 4            # significant digits of a value without an sd
SD_DIGITS = 2      # significant digits of an sd


def fmt(x: Any, sig: int = 4) -> str:
    """A number with ``sig`` significant digits (fixed notation in 1e-5..1e5), '–' for none/NaN."""
    if x is None:
        return "–"
    if isinstance(x, (int, np.integer)) and not isinstance(x, bool):
        return str(int(x))
    try:
        x = float(x)
    except (TypeError, ValueError):
        return str(x)
    if not math.isfinite(x):
        return "–" if math.isnan(x) else ("∞" if x > 0 else "-∞")
    if x == 0:
        return "0"
    a = abs(x)
    if a >= 1e5 or a < 1e-5:
        return f"{x:.{sig - 1}e}"
    decimals = max(0, sig - 1 - int(math.floor(math.log10(a))))
    return f"{x:.{decimals}f}"


def fmt_at(x: Any, sd: Any, sig: int = 4) -> str:
    """A value with at least ``sig`` significant digits and enough decimals to show its sd to two
    digits (G = 2.31952 with sd 0.00059, not 2.320); a value that rounds to zero at those decimals
    is zero (G = 2.6e-19 with sd 16 reads 0, not 2.556e-19)."""
    try:
        x, sd = float(x), float(sd)
    except (TypeError, ValueError):
        return fmt(x, sig)
    if not (math.isfinite(x) and math.isfinite(sd) and sd > 0) or x == 0:
        return fmt(x, sig)
    d_sd = 1 - int(math.floor(math.log10(sd)))
    if abs(x) < 0.5 * 10.0 ** -d_sd:      # zero at the sd's last digit (an optimum on a bound at 0)
        return "0" if d_sd <= 0 else f"{0:.{min(10, d_sd)}f}"
    if not 1e-5 <= abs(x) < 1e5:
        return fmt(x, sig)
    d_sig = sig - 1 - int(math.floor(math.log10(abs(x))))
    return f"{x:.{min(10, max(0, d_sig, d_sd))}f}"


def fmt_sd(sd: Any) -> str:
    """An sd (or any uncertainty) to SD_DIGITS significant digits: 13.77 -> '14'."""
    return fmt(sd, SD_DIGITS)


def pm(x: Any, sd: Any) -> str:
    """'value ± sd' by the package's rule ('2869 ± 14'); the value alone when there is no sd."""
    if sd is None or x is None:
        return fmt(x)
    return f"{fmt_at(x, sd)} ± {fmt_sd(sd)}"


def interval(lo: Any, hi: Any, sd: Any) -> str:
    """'[lo, hi]' at the decimals of ``sd`` (the sd of the value the interval is about)."""
    return f"[{fmt_at(lo, sd)}, {fmt_at(hi, sd)}]"


def err_pct(err: Any) -> str:
    """A relative sd (Err, eq. 33) in percent with 3 decimals; 'nan' when it is not finite and
    '>1e4' when the estimate is (nearly) zero, e.g. on a bound (no 30-digit numbers in a table)."""
    try:
        e = 100.0 * float(err)
    except (TypeError, ValueError):
        return "nan"
    if not math.isfinite(e):
        return "nan"
    return f"{e:.3f}" if abs(e) < 1e4 else ">1e4"


def share(x: float) -> str:
    """A share of a whole (a kernel's weight) as a percentage to 3 digits, 0 % and 100 % when it
    rounds there at 0.1 % ('7.15e-280' -> '0 %', '0.2503' -> '25 %', '0.0123' -> '1.23 %')."""
    v = 100.0 * float(x)
    if v < 0.05:
        return "0 %"
    if v > 99.95:
        return "100 %"
    return f"{v:.3g} %"


def pct(x: float | None, digits: int = 2) -> str:
    """A fraction as a percentage ('0.0137' -> '1.37 %'); '>1e4 %' beyond, as ``err_pct`` (a relative
    sd of an estimate on a bound at 0 would print 20 digits)."""
    if x is None or not math.isfinite(x):
        return "–"
    return f"{100 * x:.{digits}f} %" if abs(100 * x) < 1e4 else ">1e4 %"


def frequency_text(f: float) -> str:
    """5e6 -> '5 MHz', 45 -> '45 Hz', 0.1 -> '0.1 Hz'."""
    for scale, unit in ((1e9, "GHz"), (1e6, "MHz"), (1e3, "kHz")):
        if f >= scale:
            return f"{f / scale:.3g} {unit}"
    return f"{f:.3g} Hz"
