"""Physics only (numpy/numba): the spectrum, the exponential integrator and the DNLR model."""

from bayes_dnlr.model.dnlr import DNLR, Basis, haward_thackray, simulate
from bayes_dnlr.model.spectrum import relaxation_times, tau_scale, weights

__all__ = ["DNLR", "Basis", "haward_thackray", "relaxation_times", "simulate", "tau_scale",
           "weights"]
