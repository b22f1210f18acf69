"""bayes_dnlr.inference.discrepancy."""
