"""``python -m bayes_dnlr``: see ``bayes_dnlr.cli``."""

import sys

from bayes_dnlr.cli import main

sys.exit(main())
