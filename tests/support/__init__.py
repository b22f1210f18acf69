"""What several test files share: synthetic cases and runs, the real curves, the export corpus, the
crash zygote. Test files import from here (``from support.sampling import write_case``), never from
each other; pyproject's ``pythonpath = ["tests"]`` puts this package on the path.

- ``sampling``: a synthetic test as CSV + config (``write_case``), the truth, calibration replicates;
- ``runs``: small fitted or sampled run folders (``make_run``) and their truths;
- ``joint``: several tests in one run; ``batch``: a tiny campaign; ``population``: draws of specimens;
- ``finished_run``: a run folder with fit, chains and summary, made once;
- ``chains``: blocks of walker states for the chain file; ``likelihood``: configs and data for the
  posterior's tests; ``model``: the paper's parameters, a ramp, and the ODE reference solution;
- ``crash``: the zygote that forks killed ``sample`` processes;
- ``export_corpus``: machine exports made by the package; ``real_data``: where the real curves are.
"""

from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
