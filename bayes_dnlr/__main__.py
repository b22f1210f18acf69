"""``python -m bayes_dnlr``: see ``bayes_dnlr.cli``."""

from bayes_dnlr.cli import exit_now, main

exit_now(main(ends_process=True))
