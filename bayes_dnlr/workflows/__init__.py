"""bayes_dnlr.workflows."""
