"""Configs and data for the posterior's tests: white and discrepancy configs without a file, the
discrepancy priors, and a test on a jittered grid with a noisy strain."""

from __future__ import annotations

import numpy as np

from bayes_dnlr.config import parse_config


def white_config(relaxation: bool = False, sigma0: object = 0.3, parameters: dict | None = None):
    """A one-test config with the white likelihood (relaxation from 80 s when asked)."""
    raw = {"name": "t",
           "data": {"file": "x.csv", "columns": {"time": "t", "strain": "e", "stress": "s"},
                    "observable": "stress"},
           "noise": {"sigma0": sigma0, "discrepancy": "none"}}
    if relaxation:
        raw["data"]["relaxation_start"] = 80.0
    if parameters:
        raw["parameters"] = parameters
    return parse_config(raw)


def discrepancy_config(kernel: str, axis: str, relaxation: bool = False):
    """A one-test config with the model-discrepancy likelihood of ``kernel`` along ``axis``."""
    raw = {"name": "t",
           "data": {"file": "x.csv", "columns": {"time": "t", "strain": "e", "stress": "s"},
                    "observable": "stress"},
           "noise": {"sigma0": 0.3, "discrepancy": {"kernel": kernel, "axis": axis}}}
    if relaxation:
        raw["data"]["relaxation_start"] = 80.0
    return parse_config(raw)


def discrepancy_priors(high: float):
    """The discrepancy's amplitude and length priors, the length up to ``high``."""
    from bayes_dnlr.config import ParameterSpec

    return {"disc_amplitude": ParameterSpec(prior="half-normal", scale=2.0),
            "disc_length": ParameterSpec(prior="log-uniform", low=1e-4, high=high)}


def wobbly(test):
    """The test on a jittered time grid, driven by a noisy (non-monotone) strain."""
    from dataclasses import replace

    rng = np.random.default_rng(11)
    t = np.cumsum(np.r_[0.0, np.diff(test.time) * (1 + 0.3 * (rng.uniform(size=test.time.size - 1) - 0.5))])
    e = test.strain_input + rng.normal(0.0, 2e-4, t.size)
    return replace(test, time=t, strain=e, strain_input=e)


def irregular_axis(n: int = 300, seed: int = 1) -> np.ndarray:
    """An uneven grid with a repeated point and a long gap (as on a strain axis or a hold)."""
    rng = np.random.default_rng(seed)
    x = np.sort(rng.uniform(0.0, 100.0, n))
    x[50] = x[49]
    x[200:] += 150.0
    return x
