"""bayes_dnlr.inference.posterior."""
