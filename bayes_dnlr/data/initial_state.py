"""The state of the specimen before the first sample: toe compensation and an unloaded start.

The model (paper section 3) starts from the relaxed state at the first sample: an unloaded
specimen when the strain there is zero. A record whose toe was cropped, or that starts under a
preload, breaks that assumption and biases E. Two remedies, both as the standards
define them:

- **Toe compensation** (ASTM D638 Appendix X1; ISO 527-1 zero-point correction): the linear part of
  the nominal stress-strain curve is continued down to zero stress; that intersection, point B, is
  the corrected zero of strain, from which all strains are measured. Samples before B (the toe:
  slack, seating) are left out, and an unloaded sample at B is put before the first kept sample, so
  the model starts unloaded at B. The linear part is the steepest stretch below half the stress
  maximum (the tangent at maximum slope of X1.3), or a stress band the config gives.
- **initial_state: ramp-from-zero**: the strain is right (measured from the unloaded length) but
  the first rows are missing: an unloaded sample at zero strain is put before the first sample, at
  the time the initial strain rate gives.

The prepended sample is model-only: it is never compared with data (``TestData.virtual_start``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bayes_dnlr.config import ToeBand
from bayes_dnlr.data.checks import initial_slope
from bayes_dnlr.data.errors import DataError


@dataclass
class Start:
    """What to do before the first sample: drop ``cut`` leading rows, shift the Hencky strain by
    ``shift``, and prepend an unloaded sample at ``origin_time`` (None: no prepended sample)."""

    cut: int = 0
    shift: float = 0.0
    origin_time: float | None = None
    notes: list[str] = field(default_factory=list)


def _rate(time: np.ndarray, strain: np.ndarray, n: int = 20) -> float:
    """Least-squares strain rate over the first n samples."""
    k = min(n, time.size)
    t, e = time[:k], strain[:k]
    tc = t - t.mean()
    return float(np.dot(tc, e - e.mean()) / np.dot(tc, tc))


def toe_point(nominal_strain: np.ndarray, nominal_stress: np.ndarray, band: ToeBand | None
              ) -> tuple[float, float, int, int]:
    """Point B of ASTM D638 X1: (nominal strain at zero stress on the linear part, its slope, and the
    first and last sample of the linear part)."""
    e, s = nominal_strain, nominal_stress
    if band is not None:
        top = int(np.argmax(s))
        idx = np.flatnonzero((s[:top + 1] >= band.stress_min) & (s[:top + 1] <= band.stress_max))
        if idx.size < 3:
            raise DataError(f"data.toe: {{stress_min: {band.stress_min:g}, stress_max: {band.stress_max:g}}}"
                            f" holds {idx.size} sample(s) of the rising curve (nominal stress "
                            f"{s[0]:.4g} to {s[top]:.4g} MPa): at least 3 are needed")
        a, b = int(idx[0]), int(idx[-1]) + 1
        x, y = e[a:b], s[a:b]
        xc = x - x.mean()
        slope = float(np.dot(xc, y - y.mean()) / np.dot(xc, xc))
    else:
        slope, a, b = initial_slope(e, s)
    if not np.isfinite(slope) or slope <= 0:
        raise DataError(f"data.toe: no rising linear part found (slope {slope:.3g} MPa): the stress does "
                        f"not grow with the strain at the start of the test")
    x, y = e[a:b], s[a:b]
    e_b = float(x.mean() - y.mean() / slope)
    return e_b, slope, a, b


def plan_start(time: np.ndarray, strain: np.ndarray, nominal_strain: np.ndarray,
               nominal_stress: np.ndarray | None, toe: str | ToeBand, initial_state: str | None,
               lines: np.ndarray) -> Start:
    """The start for ``data.toe`` and ``data.initial_state`` (see the module docstring)."""
    if toe != "none":
        if nominal_stress is None:
            raise DataError("data.toe: compensation needs a stress (a force with area0, or a stress column)")
        band = toe if isinstance(toe, ToeBand) else None
        e_b, slope, a, b = toe_point(nominal_strain, nominal_stress, band)
        cut = int(np.argmax(nominal_strain > e_b)) if np.any(nominal_strain > e_b) else time.size
        if cut >= time.size - 3:
            raise DataError(f"data.toe: point B (nominal strain {e_b:.4g}) leaves fewer than 3 samples")
        shift = float(np.log1p(e_b))
        corrected = strain[cut:] - shift
        if cut > 0:
            e0, e1 = nominal_strain[cut - 1], nominal_strain[cut]
            t_b = float(time[cut - 1] + (e_b - e0) / (e1 - e0) * (time[cut] - time[cut - 1]))
        else:
            rate = _rate(time, strain)
            if not rate > 0:
                raise DataError(f"data.toe: point B lies before the first sample, and the strain does "
                                f"not rise there (rate {rate:.3g} 1/s) to reach it")
            t_b = float(time[0] - corrected[0] / rate)
        how = ("the band " + f"{band.stress_min:g}-{band.stress_max:g} MPa" if band else
               "the steepest stretch below half the stress maximum")
        notes = [f"toe compensation (ASTM D638 X1, ISO 527-1 zero point): linear part lines {lines[a]}-"
                 f"{lines[b - 1]} ({how}), slope {slope:.5g} MPa; point B at nominal strain {e_b:.5g}, "
                 f"t = {t_b:.6g} s: strains are measured from B (Hencky shift {shift:.5g})"]
        if cut:
            notes.append(f"toe compensation: the {cut} sample(s) before B (lines {lines[0]}-"
                         f"{lines[cut - 1]}, the toe) are left out")
        origin = t_b if t_b < time[cut] else None
        if origin is not None:
            notes.append(f"an unloaded model-only sample at B (t = {t_b:.6g} s) starts the model; it is not "
                         f"compared with data")
        return Start(cut, shift, origin, notes)
    if initial_state == "ramp-from-zero":
        if not strain[0] > 0:
            return Start(notes=[f"initial_state: ramp-from-zero: the first sample is already at strain "
                                f"{strain[0]:.3g}: nothing to add"])
        rate = _rate(time, strain)
        if not rate > 0:
            raise DataError(f"data.initial_state: ramp-from-zero: the strain does not rise at the start "
                            f"(rate {rate:.3g} 1/s over the first samples)")
        t0 = float(time[0] - strain[0] / rate)
        return Start(origin_time=t0, notes=[
            f"initial_state: ramp-from-zero: an unloaded model-only sample at t = {t0:.6g} s (strain 0, "
            f"reached at the initial rate {rate:.4g} 1/s) starts the model before the first sample "
            f"(strain {strain[0]:.4g}); it is not compared with data"])
    return Start()
