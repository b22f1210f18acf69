"""bayes_dnlr.workflows.population."""
