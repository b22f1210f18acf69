"""The note before the model's first compile on a machine (bayes_dnlr/model/compiled.py)."""

from __future__ import annotations

import importlib.util
import sys

import numpy as np
from support.sampling import write_case

from bayes_dnlr.model import compiled, simulate

SOURCE = """from numba import njit


@njit(cache=True)
def twice(x):
    return 2.0 * x
"""


def _load(path):
    """The module at ``path``, imported anew (its functions are new dispatchers)."""
    name = path.stem
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    finally:
        del sys.modules[name]
    return module


def test_machine_code_is_there_once_the_function_was_compiled(tmp_path) -> None:
    path = tmp_path / "compiled_probe.py"
    path.write_text(SOURCE)
    module = _load(path)
    assert not compiled.has_machine_code(module.twice)          # nothing in tmp_path/__pycache__ yet
    assert module.twice(1.5) == 3.0                             # compiles, and keeps the code
    assert compiled.has_machine_code(module.twice)
    assert compiled.has_machine_code(_load(path).twice)         # as another process finds it


def test_no_note_once_the_model_ran_here() -> None:
    """The note reads the integrator's cache (``fit`` compiles it), not the stress's (``simulate``):
    both run here, so that the test holds on a fresh clone run alone too."""
    from bayes_dnlr.model.dnlr import DNLR

    t, e = np.linspace(0.0, 10.0, 20), np.linspace(0.0, 0.01, 20)
    simulate(t, e, {"E": 1000.0, "G": 1.0, "tau_max": 5.0})
    DNLR(t, e).basis(5.0, grad=True)
    assert compiled.first_compile_note() is None


def test_fit_and_sample_say_they_compile_unless_quiet(tmp_path, cli_here, monkeypatch) -> None:
    monkeypatch.setattr(compiled, "first_compile_note", lambda: compiled.FIRST_COMPILE_NOTE)
    cfg = write_case(tmp_path, n=200, sampler={"max_steps": 40, "target_ess": 20})
    ran = cli_here("fit", str(cfg))
    assert ran.returncode == 0 and ran.stderr.splitlines()[0] == compiled.FIRST_COMPILE_NOTE
    ran = cli_here("fit", str(cfg), "--force", "--quiet")
    assert ran.returncode == 0 and compiled.FIRST_COMPILE_NOTE not in ran.stderr
    ran = cli_here("sample", str(cfg))
    assert ran.returncode == 0 and ran.stderr.splitlines()[0] == compiled.FIRST_COMPILE_NOTE
