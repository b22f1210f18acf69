"""FE material cards with uncertainty from a finished run (``python -m bayes_dnlr export``):
the small-strain Prony series of the DNLR model (prony.py), the cards at posterior quantiles and
draws (cards.py), a shifted model's shift law as the cards carry it (shift_law.py), one writer per
format (abaqus.py, lsdyna.py, ansys.py, table.py) and the command (run.py). docs/export.md.

Nothing heavy is imported here, so that the command line's ``--help`` stays instant.
"""

FORMAT_NAMES = ("abaqus", "ls-dyna", "ansys", "csv", "json")
