"""`make demo` compiles the discrepancy's kernels ahead (workflows/warm.py), and a `sample` that
will compile them says so before the wait (inference/discrepancy/compiled.py)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from bayes_dnlr.cli import main
from bayes_dnlr.inference.discrepancy import compiled
from bayes_dnlr.workflows.warm import write_case


def test_a_sample_that_will_compile_the_model_error_kernels_says_so_before_the_wait(tmp_path, capsys,
                                                                                    monkeypatch):
    """With the kernels missing the note comes before the progress bar (the wait used to follow the
    bar, silent); the warm-up's test takes the discrepancy likelihood, as a real curve does."""
    path = write_case(tmp_path)
    monkeypatch.setattr(compiled, "missing", lambda: ["taken for missing"])
    capsys.readouterr()
    assert main(["sample", str(path)]) == 0
    err = capsys.readouterr().err
    assert compiled.FIRST_COMPILE_NOTE in err
    assert err.index(compiled.FIRST_COMPILE_NOTE) < err.index("sampling:")
    summary = json.loads((path.parent / "summary.json").read_text())
    assert summary["noise"]["model"] == "discrepancy"


RUN = """
import contextlib, io, json, shutil, sys
from pathlib import Path
from bayes_dnlr.cli import main
from bayes_dnlr.inference.discrepancy.compiled import kernels, missing
from bayes_dnlr.workflows.warm import warm, write_case

root = Path(sys.argv[1])
def run(folder, *args):
    folder.mkdir()
    shutil.copy(sys.argv[2], folder)
    shutil.copy(Path(sys.argv[2]).with_name("hdpe-a-5e-3.csv"), folder)
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        return main(["sample", str(folder / "config.yaml"), "--quiet", *args])
cache = lambda: sorted(p.name for p in Path(sys.argv[3]).rglob("*.nbi"))
assert run(root / "hdpe-a-5e-3") == 0                      # make demo's sample: white residuals
after_demo = missing()
took = warm()
before = cache()
other = write_case(root / "other")                          # a test with model error, another seed
with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
    assert main(["sample", str(other), "--quiet"]) == 0
print(json.dumps({"after_demo": after_demo, "kernels": list(kernels()), "took": took,
                  "left": missing(), "new": sorted(set(cache()) - set(before))}))
"""


@pytest.mark.slow      # every kernel compiled from an empty cache: 40-60 s of CPU
def test_after_the_demo_and_the_warm_up_a_run_with_model_error_compiles_nothing(tmp_path):
    from support import REPO

    cache = tmp_path / "numba-cache"
    done = subprocess.run([sys.executable, "-c", RUN, str(tmp_path), str(REPO / "runs" / "hdpe-a-5e-3" /
                           "config.yaml"), str(cache)], capture_output=True, text=True, timeout=1200,
                          env={**__import__("os").environ, "NUMBA_CACHE_DIR": str(cache)})
    assert done.returncode == 0, done.stderr[-3000:]
    out = json.loads(done.stdout.strip().splitlines()[-1])
    assert out["after_demo"] == out["kernels"]                # the demo leaves every one of them
    assert out["took"] is not None and out["left"] == []
    assert out["new"] == []                                   # the next real-like run compiles nothing
