"""bayes_dnlr.inference.mcmc."""
