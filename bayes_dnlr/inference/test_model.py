"""The DNLR model of one test as a config describes it: the strain history to the window's end, the
spectrum's size, the relaxation switch, and the shift factor with the test's temperature
(model/shift.py, ``model.shift`` and ``data.temperature``)."""

from __future__ import annotations

import numpy as np

from bayes_dnlr.config import Config
from bayes_dnlr.model import DNLR
from bayes_dnlr.model.shift import NO_SHIFT, Shift


def shift_of(cfg: Config) -> Shift:
    """The model's shift laws (``model.shift``)."""
    s = cfg.model.shift
    if s.is_none:
        return NO_SHIFT
    return Shift(s.temperature, s.reference_temperature, s.stress, s.driving)


def temperature_of(cfg: Config, test, end: int | None = None) -> float | np.ndarray | None:
    """The test's temperature as the model takes it (°C; per sample up to ``end``), or None when the
    model has no temperature shift."""
    if cfg.model.shift.temperature == "none":
        return None
    t = test.temperature
    if t is None or np.ndim(t) == 0:
        return t
    return np.asarray(t)[:end]


def model_of(cfg: Config, test, end: int | None = None) -> DNLR:
    """The DNLR model on the test's strain history, from the first sample to ``end`` (the window's
    end when None)."""
    end = test.model_end if end is None else end
    return DNLR(test.time[:end], test.strain_input[:end], modes=cfg.model.modes,
                decades=cfg.model.decades, relaxation_start=test.relaxation_start,
                shift=shift_of(cfg), temperature=temperature_of(cfg, test, end))
