"""The run layer: config + data -> fit -> sample -> outputs in a run directory.

It owns what inference does not know about: run directories, fit.json and summary.json,
staleness of stored results, the run lock, resuming. ``fit`` and ``sample`` here are the public
``bayes_dnlr.fit`` and ``bayes_dnlr.sample``.
"""
