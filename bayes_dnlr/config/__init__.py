"""bayes_dnlr.config."""
