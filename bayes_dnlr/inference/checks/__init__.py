"""Checks of a posterior against its data and its physics, on arrays (runs/checks.py gathers them
for a run and decides the verdict):

- ``predictive``: the share of the data inside the 90 % posterior predictive band, per segment.
- ``bounds``: posterior mass against a prior bound, and the bound widened ×10.
- ``power_scaling``: power-scaling sensitivity to the prior (Kallioinen et al. 2024).
- ``physical``: σ∞ against a falling hold, time constants against the test, E against the chord.

They import numpy, ``vocabulary`` and ``inference.mcmc.ess`` only.
"""
