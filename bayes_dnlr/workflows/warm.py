"""Compile ahead the machine code a real curve needs: ``python -m bayes_dnlr.workflows.warm``.

`make demo` samples the shipped example, whose residuals are white: it compiles the model but not
the discrepancy's kernels that every real curve uses (inference/discrepancy/compiled.py). Without
this step the first real `sample` after the demo waited 10-30 s more than it sampled, most of it
silent after the progress bar. This runs the same code on a small synthetic test with a smooth
model error (150 samples, fit and a short chain with its checks, in a temporary folder), so that
numba compiles and caches exactly what such a run calls, with this machine's threads. It does
nothing when the kernels are compiled already.
"""

from __future__ import annotations

import contextlib
import io
import sys
import tempfile
import time
from pathlib import Path

import yaml

CONFIG = {
    "name": "warm",
    "data": {"file": "warm.csv", "columns": {"time": "t_s", "strain": "eps", "stress": "s"},
             "observable": "stress"},
    "noise": {"sigma0": "residuals"},
    "sampler": {"walkers": 16, "max_steps": 100, "target_ess": 1000, "seed": 1, "checkpoint_every": 100},
    "truth": {"params": {"E": 2854.0, "G": 2.32, "tau_max": 5.79}, "strain_rate": 5e-3,
              "strain_max": 0.5, "n_points": 150, "noise": {"strain_sd": 0.0, "stress_sd": 0.05},
              "model_form": {"kind": "two-process", "strength": "strong"}, "seed": 1},
}


def write_case(folder: Path) -> Path:
    """The small test with model error in ``folder/warm``: its config and data; the config's path."""
    from bayes_dnlr.config import load_config
    from bayes_dnlr.workflows.simulate import simulate_tests

    path = folder / "warm" / "config.yaml"
    path.parent.mkdir(parents=True)
    path.write_text(yaml.safe_dump(CONFIG, sort_keys=False))
    with contextlib.redirect_stdout(io.StringIO()):
        simulate_tests(load_config(path))
    return path


def warm() -> float | None:
    """Compile the discrepancy's kernels by sampling the small test with model error; the seconds
    it took, or None when nothing was missing. Raises RuntimeError when a kernel is still missing
    after the run (the run did not take the path a real curve takes)."""
    from bayes_dnlr.inference.discrepancy.compiled import missing

    if not missing():
        return None
    from bayes_dnlr.config import load_config
    from bayes_dnlr.runs.sample import sample

    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="bayes-dnlr-warm-") as folder:
        path = write_case(Path(folder))
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            sample(load_config(path), progress=False)
    left = missing()
    if left:
        raise RuntimeError(f"the warm-up run left {left} uncompiled")
    return time.perf_counter() - start


def main() -> int:
    try:
        took = warm()
    except Exception as err:  # noqa: BLE001 - a warm-up: the demo stands without it
        print(f"warning: the model-error kernels were not compiled ahead ({err}); the first real "
              "`sample` compiles them", file=sys.stderr)
        return 0
    if took is None:
        print("model-error kernels: compiled for this machine already")
    else:
        print(f"compiled the model-error kernels for this machine in {took:.0f} s (numba): the first "
              "`sample` of a real curve does not wait for them")
    return 0


if __name__ == "__main__":
    sys.exit(main())
