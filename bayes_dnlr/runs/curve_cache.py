"""The report's curves of each test (runs/curves.py), kept in the run folder's .cache by the digest
of everything they are computed from.

Computing them needs the compiled model and the discrepancy's filter: in a fresh ``report``
process, loading numba and its cached functions cost about a second, more than the curves
themselves. ``sample`` has them loaded when its posterior is written, so it computes the curves
then (``keep_report_curves``) and ``report`` reads them (``report_curves``); a report that finds
none, or stale ones, computes and keeps them itself.

The digest covers the run's outputs (fit.json, summary.json, posterior.nc), the test's config and
data arrays, and the source of the code that computes the curves: a cached set never shows other
results or another computation than the report would make.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from bayes_dnlr.digests import file_sha256
from bayes_dnlr.diskio import keep_cache_arrays
from bayes_dnlr.inference.discrepancy.axis import test_axis
from bayes_dnlr.readback import read_npz
from bayes_dnlr.runs.curves import N_DRAWS, Curves, Discrepancy, compute_curves
from bayes_dnlr.runs.layout import FIT_FILE, POSTERIOR_FILE, SMOOTHING_CACHE, SUMMARY_FILE
from bayes_dnlr.runs.results import RunResults

_PACKAGE = Path(__file__).resolve().parents[1]
# the code the curves come from: the model, the discrepancy's filter, the curves and this file
_SOURCES = ("model", "inference/discrepancy", "runs/curves.py", "runs/curve_cache.py")
_OPTIONAL = ("median", "gn_curve", "white_curve")
_PAIRS = ("band", "predictive")
_code: str | None = None


def _code_digest() -> str:
    global _code
    if _code is None:
        h = hashlib.sha256()
        for part in _SOURCES:
            path = _PACKAGE / part
            for f in sorted(path.rglob("*.py")) if path.is_dir() else [path]:
                h.update(f.relative_to(_PACKAGE).as_posix().encode())
                h.update(f.read_bytes())
        _code = h.hexdigest()
    return _code


def curves_digest(view: RunResults, test: str) -> str:
    """The digest of what a test's curves are computed from (module docstring)."""
    h = hashlib.sha256()
    h.update(_code_digest().encode())
    h.update(json.dumps([test, N_DRAWS, view.cfg.model_dump(mode="json")], sort_keys=True,
                        default=str).encode())
    for name in (FIT_FILE, SUMMARY_FILE, POSTERIOR_FILE):
        path = view.run_dir / name
        h.update(file_sha256(path).encode() if path.is_file() else b"absent")
    t = view.test
    for a in (t.time, t.stress, t.strain_input, t.window):
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype}{a.shape}".encode())
        h.update(a.tobytes())
    h.update(repr((t.model_end, t.relaxation_start)).encode())
    return h.hexdigest()


def _file(run_dir: Path, test: str, digest: str | None = None) -> Path:
    slug = "".join(c if c.isalnum() or c in "._-" else "_" for c in test)
    return run_dir / SMOOTHING_CACHE / f"curves-{slug}-{digest or '*'}.npz"


def _arrays(curves: Curves, disc: Discrepancy | None) -> dict[str, Any]:
    out: dict[str, Any] = {"x": curves.x, "data": curves.data, "window": curves.window,
                           "strain": curves.strain, "xlabel": np.array(curves.xlabel)}
    for k in _OPTIONAL:
        if getattr(curves, k) is not None:
            out[k] = getattr(curves, k)
    for k in _PAIRS:
        if getattr(curves, k) is not None:
            out[k] = np.stack(getattr(curves, k))
    for name, v in (curves.sensitivities or {}).items():
        out["sensitivity:" + name] = v
    if curves.sensitivities is not None:
        out["sensitivity_names"] = np.array(list(curves.sensitivities), dtype=str)
    if disc is not None:
        out.update({"disc_residuals": disc.residuals, "disc_mean": disc.mean,
                    "disc_whitened": disc.whitened,
                    "disc_meta": np.array(json.dumps({"kernel": disc.kernel, "hyper": disc.hyper}))})
    return out


def _read(path: Path, view: RunResults) -> tuple[Curves, Discrepancy | None] | None:
    a = read_npz(path)
    if a is None:
        return None
    try:
        return _curves_of(a, view)
    except (KeyError, IndexError, TypeError, ValueError):
        return None              # another file in its place: computed again, as a missing one


def _curves_of(a: dict, view: RunResults) -> tuple[Curves, Discrepancy | None]:
    curves = Curves(x=a["x"], xlabel=str(a["xlabel"]), data=a["data"], window=a["window"],
                    strain=a["strain"], **{k: a.get(k) for k in _OPTIONAL})
    for k in _PAIRS:
        if k in a:
            setattr(curves, k, (a[k][0], a[k][1]))
    if "sensitivity_names" in a:
        curves.sensitivities = {str(n): a["sensitivity:" + str(n)] for n in a["sensitivity_names"]}
    disc = None
    if "disc_meta" in a:
        meta = json.loads(str(a["disc_meta"]))
        t = view.test
        axis = test_axis(view.cfg.noise.discrepancy, t, np.asarray(t.window[:t.model_end], bool))
        disc = Discrepancy(meta["kernel"], axis.name, axis, a["disc_residuals"], a["disc_mean"],
                           a["disc_whitened"], meta["hyper"])
    return curves, disc


def _store(run_dir: Path, test: str, digest: str, curves: Curves, disc: Discrepancy | None) -> None:
    """Keep a test's curves, replacing the ones it had (a cache that cannot be written is no error:
    the next report computes them)."""
    path = _file(run_dir, test, digest)
    if not keep_cache_arrays(path, **_arrays(curves, disc)):
        return
    for old in path.parent.glob(_file(run_dir, test).name):
        if old != path:
            old.unlink(missing_ok=True)


def report_curves(view: RunResults, test: str) -> tuple[Curves, Discrepancy | None]:
    """A test's curves and discrepancy (runs/curves.py ``compute_curves``): the kept ones when they
    belong to the current outputs, data and code, else computed and kept."""
    digest = curves_digest(view, test)
    path = _file(view.run_dir, test, digest)
    if path.is_file():
        hit = _read(path, view)
        if hit is not None:
            return hit
    curves, disc = compute_curves(view)
    _store(view.run_dir, test, digest, curves, disc)
    return curves, disc


def keep_report_curves(run_dir: Path, tests: Mapping[str, Any] | None = None) -> None:
    """Compute and keep the curves of every test of a finished run (``sample`` calls this while its
    compiled model is loaded); ``tests``: the tests' data already read, by name."""
    from bayes_dnlr.runs.results import load_run

    run = load_run(run_dir, tests=tests, provenance=False)
    for name, view in run.tests.items():
        if view.test is not None:
            report_curves(view, name)
