"""Whether this machine has the discrepancy's machine code yet (model/compiled.py for the model).

A real curve's first `sample` compiles the discrepancy's Kalman filter for the sampler (one walker
per SIMD lane: lanes.py) and for the checks that follow it (the smoother of the predictive band:
kalman.py). After `make demo`, whose example needs no model error, that took 10-30 s on this
project's 2-core machine, most of it after the progress bar, without a word. `make demo` now
compiles them ahead (workflows/warm.py), and a command that will need them says so before the
wait when they are missing.
"""

from __future__ import annotations

import sys

FIRST_COMPILE_NOTE = ("compiling the model-error kernels for this machine (numba, the first run of "
                      "this copy only: 10-30 s, part of it after the sampling, for the checks; "
                      "`make demo` compiles them ahead)")


def kernels() -> dict[str, object]:
    """name -> the njit functions a run with the discrepancy compiles beyond the example's (a fit's
    analysis compiles the rest): the sampler's filter, one walker per lane, on one thread and on
    several, and the filter, smoother and log-determinant of the checks."""
    from bayes_dnlr.inference.discrepancy import kalman, lanes

    return {"kalman.loglike": kalman.loglike, "kalman.combine": kalman.combine,
            "kalman._chol_logdet": kalman._chol_logdet, "kalman._smooth_mean": kalman._smooth_mean,
            "lanes._lanes_exp": lanes._lanes_exp, "lanes._groups_exp": lanes._groups_exp}


def missing() -> list[str]:
    """The kernels without machine code on this machine (numba's on-disk cache)."""
    from bayes_dnlr.model.compiled import has_machine_code

    return [name for name, f in kernels().items() if not has_machine_code(f)]


def announce_first_compile() -> None:
    """Print FIRST_COMPILE_NOTE on stderr when a kernel has no machine code yet."""
    if missing():
        print(FIRST_COMPILE_NOTE, file=sys.stderr, flush=True)
