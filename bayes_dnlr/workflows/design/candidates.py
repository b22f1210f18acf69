"""The planned test conditions: every combination of the design's grids is a candidate, and each
candidate is the test ``simulate`` would make (synthetic.protocol: a ramp at a constant true strain
rate to strain_max, then the hold, sampled at n_points or sample_rate)."""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from bayes_dnlr.config import ConfigError, TruthConfig, Window
from bayes_dnlr.workflows.design.config import DesignConfig, DesignWindow
from bayes_dnlr.workflows.simulate import Protocol, protocol


@dataclass(frozen=True)
class Candidate:
    """One planned test."""

    index: int
    strain_rate: float            # 1/s
    strain_max: float             # Hencky
    sample_rate: float | None     # Hz (or None when n_points is planned)
    n_points: int | None          # samples over the whole test (or None with sample_rate)
    hold: float                   # s
    window: str                   # name of the identification window
    window_spec: DesignWindow

    @property
    def ramp_time(self) -> float:
        return self.strain_max / self.strain_rate

    @property
    def duration(self) -> float:
        """Ramp plus hold, s."""
        return self.ramp_time + self.hold

    @property
    def total_points(self) -> int:
        """Samples of the whole test (the rule of synthetic.protocol)."""
        if self.n_points is not None:
            return int(self.n_points)
        n_ramp = max(1, round(self.ramp_time * self.sample_rate))
        n_hold = round(self.hold * self.sample_rate) if self.hold > 0 else 0
        return 1 + n_ramp + n_hold

    def label(self) -> str:
        samp = (f"{self.sample_rate:g} Hz" if self.sample_rate is not None else f"{self.n_points} points")
        hold = f", hold {self.hold:g} s" if self.hold > 0 else ""
        return (f"rate {self.strain_rate:.3g} 1/s to strain {self.strain_max:g}, {samp}{hold}, "
                f"window {self.window}")


def expand(cfg: DesignConfig) -> list[Candidate]:
    """Every combination of the planned conditions, in a stable order."""
    c = cfg.conditions
    samplings = ([(float(s), None) for s in c.sample_rate.points()] if c.sample_rate is not None
                 else [(None, int(round(n))) for n in c.n_points.points()])
    out = []
    for rate, emax, (sr, npts), hold, (wname, w) in itertools.product(
            c.strain_rate.points(), c.strain_max.points(), samplings, c.hold.points(), c.windows.items()):
        out.append(Candidate(len(out), float(rate), float(emax), sr, npts, float(hold), wname, w))
    return out


def planned_protocol(c: Candidate, params: dict[str, float]) -> Protocol:
    """The noise-free test of a candidate, exactly as ``simulate`` writes it."""
    truth = TruthConfig(params=params, strain_rate=c.strain_rate, strain_max=c.strain_max, hold=c.hold,
                        n_points=c.n_points, sample_rate=c.sample_rate)
    try:
        return protocol(truth, np.random.default_rng(0))
    except ConfigError as err:
        raise ConfigError(f"conditions: {c.label()}: {str(err).removeprefix('truth.')}") from None


def window_mask(w: Window, time: np.ndarray, strain: np.ndarray) -> np.ndarray:
    """The samples of the identification window (bounds on the planned time and strain)."""
    m = np.ones(time.size, bool)
    if w.strain_min is not None:
        m &= strain >= w.strain_min
    if w.strain_max is not None:
        m &= strain <= w.strain_max
    if w.time_min is not None:
        m &= time >= w.time_min
    if w.time_max is not None:
        m &= time <= w.time_max
    return m
