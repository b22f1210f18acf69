"""bayes_dnlr.workflows.batch."""
