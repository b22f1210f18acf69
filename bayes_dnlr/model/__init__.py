"""Physics only (numpy/numba): the spectrum, the exponential integrator and the DNLR model."""

from bayes_dnlr.model.dnlr import DNLR, Basis, cached_model, simulate
from bayes_dnlr.model.spectrum import relaxation_times, tau_scale, weights
from bayes_dnlr.model.threads import default_threads, get_threads, set_threads

__all__ = ["DNLR", "Basis", "cached_model", "default_threads", "get_threads", "relaxation_times",
           "set_threads", "simulate", "tau_scale", "weights"]
