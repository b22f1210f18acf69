"""Statistics: least squares with the paper's stochastic analysis (lsq), and the posterior (mcmc).

Kept light: nothing heavy (emcee, ArviZ) is imported here; import the submodule you need, e.g.
``from bayes_dnlr.inference.lsq import fit``.
"""
