"""bayes_dnlr.inference.lsq."""
