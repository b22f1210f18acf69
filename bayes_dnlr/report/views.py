"""Which part of a test each figure shows, and what its caption says, decided from the window.

The paper's HDPE curves run to ε = 1.9 and its interval I ends at ε = 0.13 (the strain at yield):
its Fig. 12 marks that strain and zooms on the rest of the test. A run may be anything ``fit``
accepts: a pre-yield window that ends before 0.13, a relaxation test with a ramp of a few samples,
50 points in all. Each view falls back on a choice made from the data when the paper's does not
apply; nothing here assumes HDPE.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

INTERVAL_I = 0.13        # the paper's interval I (strain at yield), marked on Fig. 12
PAPER_VIEW_STRAIN = 1.5 * INTERVAL_I   # a window reaching this far gets the paper's marks and zooms
MIN_ZOOM_POINTS = 3
STRAIGHT = 0.02          # a curve within 2 % of its chord (normalised units) counts as straight


@dataclass(frozen=True)
class Inset:
    """The zoom of the fit figure: x <= xmax, with its title and a phrase for the caption."""

    xmax: float
    title: str
    caption: str


def fit_inset(x: np.ndarray, relaxation_start: float | None) -> Inset | None:
    """Tensile test reaching past 2 × 0.13: a zoom on the paper's interval I. Relaxation test whose
    ramp is short next to the hold: a zoom on the ramp and the start of the hold. Else none."""
    x = np.asarray(x, dtype=float)
    if x.size < MIN_ZOOM_POINTS:
        return None
    if relaxation_start is None:
        if x.max() >= 2 * INTERVAL_I and np.count_nonzero(x <= INTERVAL_I) >= MIN_ZOOM_POINTS:
            return Inset(INTERVAL_I, f"zoom: strain up to {INTERVAL_I:g} (the paper's interval I)",
                         f"the inset zooms on ε ≤ {INTERVAL_I:g}, the paper's interval I")
        return None
    span = float(x.max() - x.min())
    ramp = float(relaxation_start - x.min())
    if span > 0 and 0 < ramp < 0.1 * span:
        xmax = float(x.min() + 3.0 * ramp)
        if np.count_nonzero(x <= xmax) >= MIN_ZOOM_POINTS:
            return Inset(xmax, f"zoom: the ramp and the start of the hold (t ≤ {xmax:.3g} s)",
                         f"the inset zooms on the ramp and the start of the hold (t ≤ {xmax:.3g} s)")
    return None


@dataclass(frozen=True)
class XYView:
    """What ``figures.sensitivity_xy_plot`` draws (paper Fig. 12) and the caption that goes with it."""

    x_tau: np.ndarray
    x_e: np.ndarray
    colour: np.ndarray
    colour_label: str
    zoom: np.ndarray | None
    zoom_title: str
    mark: int | None
    mark_label: str
    caption: str          # HTML
    log_colour: bool = False


def bend_index(x: np.ndarray, y: np.ndarray) -> tuple[int, float]:
    """The sample farthest from the chord between the first and last points, in units normalised
    by each coordinate's range, and that distance (0 for a straight line)."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    sx, sy = np.ptp(x), np.ptp(y)
    if x.size < 3 or not (sx > 0 and sy > 0):
        return (x.size - 1 if x.size else 0), 0.0
    u, v = (x - x[0]) / sx, (y - y[0]) / sy
    du, dv = u[-1], v[-1]
    length = float(np.hypot(du, dv))
    if length == 0:
        d = np.hypot(u, v)
    else:
        d = np.abs(u * dv - v * du) / length
    k = int(np.argmax(d))
    return k, float(d[k])


_NAMES = "X̃(E) against X̃(τ<sub>max</sub>)"


def xy_view(sens: dict[str, np.ndarray], strain: np.ndarray, time: np.ndarray,
            relaxation_start: float | None) -> XYView | None:
    """The view of Fig. 12 for this run (None without both E and tau_max sensitivities)."""
    if "E" not in sens or "tau_max" not in sens:
        return None
    x_tau, x_e = np.asarray(sens["tau_max"], float), np.asarray(sens["E"], float)
    strain, time = np.asarray(strain, float)[: x_e.size], np.asarray(time, float)[: x_e.size]
    tensile = np.ones(x_e.size, bool) if relaxation_start is None else time <= relaxation_start
    n_tens = int(np.count_nonzero(tensile))
    e_max = float(np.max(strain[tensile])) if n_tens else 0.0
    eps = r"strain $\varepsilon_{11}$"

    if e_max >= PAPER_VIEW_STRAIN and n_tens >= 20:
        # the paper's view: the tensile part, ε = 0.13 marked, zoom on the rest of the test
        s = strain[tensile]
        mark = int(np.argmin(np.abs(s - INTERVAL_I)))
        zoom = s >= 0.8 * INTERVAL_I
        part = "along the tensile test" if relaxation_start is None else (
            "along the tensile part of the test (the hold is left out, as in the paper)")
        return XYView(x_tau[tensile], x_e[tensile], s, eps, zoom,
                      rf"zoom on $\varepsilon \geq$ {0.8 * INTERVAL_I:.3g} (after the rise)", mark,
                      rf"$\varepsilon$ = {INTERVAL_I:g}",
                      f"{_NAMES} {part} (paper Fig. 12). A straight line through the origin would make "
                      "E and τ<sub>max</sub> impossible to separate; the bend near the end of the "
                      f"paper's interval I (ε = {INTERVAL_I:g}, circled; right: zoom on the rest of the "
                      "test) is what identifies them.")

    if relaxation_start is None or n_tens >= 20:
        # a tensile window that ends before the paper's: mark where the curve bends most
        s = strain[tensile]
        k, dist = bend_index(x_tau[tensile], x_e[tensile])
        straight = dist < STRAIGHT
        zoom = np.arange(s.size) >= k
        if straight or k >= s.size - MIN_ZOOM_POINTS:
            zoom = s >= float(s.min()) + 0.5 * float(np.ptp(s))
        zoom_from = float(s[zoom].min()) if zoom.any() else float(s.max())
        where = ("the tensile test" if relaxation_start is None else
                 "the tensile part of the test (the hold is left out, as in the paper)")
        text = (f"{_NAMES} along {where} (paper Fig. 12), coloured by strain. The window ends at "
                f"ε = {e_max:.3g}, ")
        text += ("before the end of the paper's interval I (ε = 0.13), so the paper's mark does not "
                 "apply. " if e_max < INTERVAL_I else "short of the paper's whole test. ")
        if straight:
            text += ("The curve is nearly a straight line through the origin: on this window the "
                     "sensitivities to E and τ<sub>max</sub> are nearly proportional, and the data "
                     "cannot tell the two apart well (see ρ(E, τ<sub>max</sub>) in Δ̃).")
            mark, label = None, ""
        else:
            text += (f"Circled: where the curve bends most away from a straight line (ε = "
                     f"{s[k]:.3g}); that bend is what separates E from τ<sub>max</sub>; the further it "
                     "departs from the straight line, the better they are identified.")
            mark, label = k, rf"bend, $\varepsilon$ = {s[k]:.3g}"
        return XYView(x_tau[tensile], x_e[tensile], s, eps, zoom,
                      rf"zoom on $\varepsilon \geq$ {zoom_from:.3g}", mark, label, text)

    # a relaxation test whose ramp is too short for a tensile-only figure: the whole test, by time
    mark = n_tens - 1 if n_tens else None
    return XYView(x_tau, x_e, time, "time (s, log scale)", None, "", mark, "hold starts",
                  f"{_NAMES} over the whole test, coloured by time (log scale): the ramp holds only "
                  f"{n_tens} sample(s) up to ε = {e_max:.3g}, too few for the paper's tensile-only "
                  "Fig. 12. Circled: the start of the hold. A straight line through the origin would "
                  "make E and τ<sub>max</sub> impossible to separate; where the hold's path departs from "
                  "the ramp's, the hold tells them apart.", log_colour=True)
