"""bayes_dnlr: the true instantaneous modulus of polymers from tensile tests.

A reduced DNLR model (Blaise et al., 50 modes on a universal spectrum, Haward-Thackray relaxed
state), its least-squares identification with the paper's stochastic analysis, and the Bayesian
posterior of E, G, tau_max (and sigma_inf, tau_max_R) sampled with emcee.

    import bayes_dnlr as bd
    stress = bd.simulate(time, strain, {"E": 2854.0, "G": 2.32, "tau_max": 5.79})
    cfg = bd.load_config("runs/hdpe-a-5e-3/config.yaml")
    fit = bd.fit(cfg)
    post = bd.sample(cfg)

Heavy modules (emcee, ArviZ, matplotlib) load only when the function that needs them is called.
"""

from importlib import import_module
from typing import Any

__version__ = "0.1.0"

_LAZY = {
    "simulate": ("bayes_dnlr.model", "simulate"),
    "DNLR": ("bayes_dnlr.model", "DNLR"),
    "load_config": ("bayes_dnlr.config", "load_config"),
    "ConfigError": ("bayes_dnlr.config", "ConfigError"),
    "load_test": ("bayes_dnlr.data", "load_test"),
    "DataError": ("bayes_dnlr.data", "DataError"),
    "fit": ("bayes_dnlr.runs.fit", "fit"),
    "sample": ("bayes_dnlr.runs.sample", "sample"),
}

__all__ = ["__version__", *_LAZY]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        module, attr = _LAZY[name]
        value = getattr(import_module(module), attr)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'bayes_dnlr' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(__all__)
