"""Time of writing and reading posterior.nc: ours (h5py, by netCDF-4's conventions: runs/netcdf.py
and runs/results.py) against h5netcdf, the library that wrote and read it before, on the same
draws, in the same process.

- write: ``PosteriorDraws.to_netcdf`` against the same file written through h5netcdf (the code the
  package had: one ``create_variable`` per variable, dimensions by name);
- read: ``results.read_draws`` against the same reading through h5netcdf.

Sizes: a test's tiny run (60 steps x 8 walkers x 4 parameters) and a real curve's (2000 kept steps x
32 walkers x 6 parameters). Best of ``--repeat`` runs of 10 calls; the machine may be shared, so
read the ratios.

    .venv/bin/python benchmarks/posterior_file.py [--repeat 5]
"""

from __future__ import annotations

import argparse
import io
import tempfile
import time
from functools import partial
from pathlib import Path

import numpy as np

from bayes_dnlr.runs import results
from bayes_dnlr.runs.netcdf import SAMPLE_DIMS, PosteriorDraws
from bayes_dnlr.vocabulary import UNITS

SIZES = {"tiny (60 x 8 x 4)": (60, 8, 4), "real curve (2000 x 32 x 6)": (2000, 32, 6)}
NAMES = ["E", "G", "tau_max", "sigma0", "disc_amplitude", "disc_length"]


def h5netcdf_write(post: PosteriorDraws) -> bytes:
    """The same file through h5netcdf (the writer the package used before)."""
    import h5netcdf

    n, w, _ = post.draws.shape
    groups = {"posterior": {k: post.draws[:, :, j].T for j, k in enumerate(post.names)},
              "sample_stats": {"lp": post.log_prob.T}}
    buf = io.BytesIO()
    with h5netcdf.File(buf, "w") as f:
        for gname, variables in groups.items():
            g = f.create_group(gname)
            g.dimensions = {"chain": w, "draw": n}
            g.create_variable("chain", ("chain",), data=np.arange(w, dtype=np.int64))
            g.create_variable("draw", ("draw",), data=np.arange(n, dtype=np.int64))
            for k, v in variables.items():
                var = g.create_variable(k, SAMPLE_DIMS, data=np.ascontiguousarray(v), fillvalue=np.nan)
                if gname == "posterior":
                    var.attrs["units"] = UNITS.get(k, "")
            for k, v in post.attrs.items():
                g.attrs[k] = v
    return buf.getvalue()


def h5netcdf_read(path: Path) -> dict[str, np.ndarray]:
    """The draws through h5netcdf (the reader the package used before)."""
    import h5netcdf

    with h5netcdf.File(path, "r") as f:
        g = f.groups["posterior"]
        return {k: np.asarray(v[...], dtype=float) for k, v in g.variables.items()
                if k not in g.dimensions}


def best(func, repeat: int) -> float:
    """Seconds per call: the best of ``repeat`` runs of 10 calls."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(10):
            func()
        times.append((time.perf_counter() - t0) / 10)
    return min(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    with tempfile.TemporaryDirectory() as tmp:
        for label, (steps, walkers, ndim) in SIZES.items():
            post = PosteriorDraws(NAMES[:ndim], rng.normal(size=(steps, walkers, ndim)),
                                  rng.normal(size=(steps, walkers)), {"burn_in": 10, "moves": "de"})
            path = Path(tmp) / "posterior.nc"
            path.write_bytes(post.to_netcdf())
            ours = results.read_draws(path)
            theirs = h5netcdf_read(path)
            assert all(np.array_equal(ours[k], theirs[k]) for k in ours)
            w_ours = best(post.to_netcdf, args.repeat)
            w_ref = best(partial(h5netcdf_write, post), args.repeat)
            r_ours = best(partial(results.read_draws, path), args.repeat)
            r_ref = best(partial(h5netcdf_read, path), args.repeat)
            print(f"{label}: write {1e3 * w_ours:6.1f} ms (h5netcdf {1e3 * w_ref:6.1f} ms, "
                  f"x{w_ref / w_ours:4.1f}); read {1e3 * r_ours:5.1f} ms (h5netcdf {1e3 * r_ref:5.1f} ms, "
                  f"x{r_ref / r_ours:4.1f}); file {path.stat().st_size / 1e6:.2f} MB")


if __name__ == "__main__":
    main()
