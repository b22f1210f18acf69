"""Cycles at large strain on an elastic-plastic material, for the turning-point rule (data/cycles.py):
its test and benchmarks/turning_points.py."""

from __future__ import annotations

import numpy as np


def plastic_cycles(peaks=(0.2, 0.35, 0.5), back=0.02, step=0.0005, rate=1e-3, yield_stress=20.0,
                   modulus=1000.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Time, nominal strain and stress: a linear elastic material (``modulus``, MPa) that flows at
    ``yield_stress`` with a small hardening; each unloading takes the stress to zero while the
    strain goes back by ``back`` only (4 % of the range at 0.02 of 0.5)."""
    e = [0.0]
    for p in peaks:
        e += list(np.arange(e[-1] + step, p + 1e-12, step))
        e += list(np.arange(e[-1] - step, p - back - 1e-12, -step))
    e = np.array(e)
    plastic, s = 0.0, np.empty(e.size)
    for i, x in enumerate(e):
        trial = modulus * (x - plastic)
        if trial > yield_stress + 10.0 * plastic:
            plastic = (modulus * x - yield_stress) / (modulus + 10.0)
            trial = modulus * (x - plastic)
        s[i] = max(trial, 0.0)
    return np.arange(e.size) * step / rate, e, s
