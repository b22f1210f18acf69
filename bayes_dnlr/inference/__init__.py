"""Statistics: least squares with the paper's stochastic analysis (lsq), the likelihood, priors,
and emcee on a log-density (mcmc). Nothing here knows about run directories (see pipeline/).

Kept light: nothing heavy (emcee, ArviZ) is imported here; import the submodule you need, e.g.
``from bayes_dnlr.inference.lsq.identify import fit_test``.
"""
