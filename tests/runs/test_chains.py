"""chains.h5: exact round trip, readable while written (SWMR), recovery after SIGKILL."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from support import REPO
from support.chains import create_writer, make_blocks, phys

from bayes_dnlr.errors import DamagedFileError
from bayes_dnlr.runs.chains import ChainWriter, read_attrs, read_run


def test_round_trip_is_exact(tmp_path: Path) -> None:
    path = tmp_path / "chains.h5"
    w = create_writer(path)
    blocks = list(make_blocks(1, 3))
    for k, (z, lp, acc, st) in enumerate(blocks):
        w.append(z, lp, acc, st, elapsed=1.5 * (k + 1), n_evals=100 * (k + 1))
    w.finish({"stop_reason": "converged"})
    run = read_run(path)
    assert run.steps == 30 and run.finished and run.attrs["stop_reason"] == "converged"
    np.testing.assert_array_equal(run.chain, phys(np.concatenate([b[0] for b in blocks])))
    np.testing.assert_array_equal(run.log_prob, np.concatenate([b[1] for b in blocks]))
    np.testing.assert_array_equal(run.accepted, np.concatenate([b[2] for b in blocks]))
    np.testing.assert_array_equal(run.checkpoint_steps, [0, 10, 20, 30])
    last = blocks[-1][3]
    np.testing.assert_array_equal(run.state.coords, last.coords)
    np.testing.assert_array_equal(run.state.log_prob, last.log_prob)
    # the RNG state restores the same stream
    a, b = np.random.RandomState(), np.random.RandomState()
    a.set_state(last.rng)
    b.set_state(run.state.rng)
    np.testing.assert_array_equal(a.standard_normal(50), b.standard_normal(50))
    assert run.elapsed == 4.5 and run.n_evals == 300
    assert run.names == ["E", "G", "tau_max"]
    assert read_attrs(path)["fingerprint"] == "abc"
    assert run.store_time > 0


def test_chunked_and_compressed(tmp_path: Path) -> None:
    import h5py

    path = tmp_path / "chains.h5"
    w = create_writer(path)
    w.close()
    with h5py.File(path, "r", libver="latest", swmr=True) as f:
        for name in ("chain", "log_prob", "accepted"):
            assert f[name].chunks is not None and f[name].compression == "gzip"
            assert f[name].maxshape[0] is None


READER = textwrap.dedent("""
    import sys
    from bayes_dnlr.runs.chains import read_run
    run = read_run(sys.argv[1])
    print(run.steps, run.checkpoint_steps.size, float(run.chain[-1].sum()) if run.steps else 0.0)
""")


def test_readable_by_another_process_while_open_for_writing(tmp_path: Path) -> None:
    path = tmp_path / "chains.h5"
    w = create_writer(path)
    blocks = list(make_blocks(2, 3))
    seen = []
    for z, lp, acc, st in blocks:
        w.append(z, lp, acc, st, elapsed=1.0, n_evals=1)
        out = subprocess.run([sys.executable, "-c", READER, str(path)], capture_output=True,
                             text=True, timeout=60)
        assert out.returncode == 0, out.stderr
        seen.append(out.stdout.split())
    # the writer is still open and appending works after the readers came and went
    assert w.steps == 30
    w.close()
    assert [s[:2] for s in seen] == [["10", "2"], ["20", "3"], ["30", "4"]]
    assert float(seen[-1][2]) == pytest.approx(float(phys(blocks[-1][0])[-1].sum()))


KILLED_WRITER = textwrap.dedent("""
    import os, signal, sys
    import numpy as np
    sys.path.insert(0, sys.argv[2])
    from support.chains import create_writer, make_blocks
    w = create_writer(__import__("pathlib").Path(sys.argv[1]))
    blocks = list(make_blocks(3, 3))
    for z, lp, acc, st in blocks[:2]:
        w.append(z, lp, acc, st, elapsed=1.0, n_evals=1)
    # a third block reaches the file but its checkpoint does not: it must not count
    f = w._f
    f["chain"].resize(30, axis=0)
    f["chain"][20:] = blocks[2][0]
    f["chain"].flush()
    os.kill(os.getpid(), signal.SIGKILL)
""")


def test_recovers_after_sigkill_and_appends(tmp_path: Path) -> None:
    path = tmp_path / "chains.h5"
    out = subprocess.run([sys.executable, "-c", KILLED_WRITER, str(path), str(REPO / "tests")],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == -9, out.stderr
    import h5py

    with pytest.raises(OSError):       # HDF5 refuses a plain write-open of a killed SWMR writer's file
        h5py.File(path, "r+")
    run = read_run(path)
    blocks = list(make_blocks(3, 4))
    assert run.steps == 20 and not run.finished
    np.testing.assert_array_equal(run.chain, phys(np.concatenate([b[0] for b in blocks[:2]])))
    np.testing.assert_array_equal(run.state.coords, blocks[1][3].coords)
    w = ChainWriter.resume(path, phys)
    for z, lp, acc, st in blocks[2:]:
        w.append(z, lp, acc, st, elapsed=2.0, n_evals=2)
    w.finish({"stop_reason": "max_steps"})
    run = read_run(path)
    assert run.steps == 40 and run.finished
    np.testing.assert_array_equal(run.checkpoint_steps, [0, 10, 20, 30, 40])
    np.testing.assert_array_equal(run.chain, phys(np.concatenate([b[0] for b in blocks])))


def test_not_a_chain_file(tmp_path: Path) -> None:
    import h5py

    path = tmp_path / "chains.h5"
    with h5py.File(path, "w", libver="latest") as f:
        f["x"] = 1
    with pytest.raises(DamagedFileError, match="not a bayes_dnlr chain file"):
        read_run(path)
