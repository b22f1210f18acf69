"""bayes_dnlr.inference.analyses."""
