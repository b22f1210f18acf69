"""Coverage of the linearized ±1.96 sd interval of `fit` over noisy synthetic replicates.

    .venv/bin/python benchmarks/coverage_lsq.py [--replicates 300] [--config runs/hdpe-a-5e-3/config.yaml]

Two settings, Table 3 parameters (E 2854, G 2.32, tau_max 5.79) at 5e-3 1/s, 2000 points, 0.3 MPa:
1. exact strain input, stress noise only (the paper's eq. 30 assumptions), sigma0 from the residuals;
2. the whole pipeline: ``simulate_test`` (noisy strain, sd 1e-4, and noisy stress) -> ``load_test``
   (strain_input smoothed, or measured) -> ``fit_test``, sigma0 known (0.3) and from the residuals.
Prints the coverage per parameter (nominal 95 %), the mean bias in sd and the mean (est-truth)/truth.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

REPO = Path(__file__).resolve().parents[1]
TABLE3 = {"E": 2854.0, "G": 2.32, "tau_max": 5.79}


def summary(label: str, est: np.ndarray, sd: np.ndarray, truth: dict[str, float], wall: float) -> None:
    names = list(truth)
    t = np.array([truth[k] for k in names])
    z = (est - t) / sd
    cover = np.mean(np.abs(z) <= 1.96, axis=0)
    rel = 100 * np.mean(est / t - 1, axis=0)
    bias, spread = np.mean(z, axis=0), np.std(z, axis=0)
    parts = [f"{k} {100 * c:5.1f} % (bias {bias[j]:+.2f} sd, {rel[j]:+.3f} %, sd(z) {spread[j]:.2f})"
             for j, (k, c) in enumerate(zip(names, cover, strict=True))]
    print(f"{label} [{est.shape[0]} replicates, {wall:.1f} s]:\n    " + "\n    ".join(parts))


def exact_input(n_rep: int) -> None:
    from bayes_dnlr.config import parse_config
    from bayes_dnlr.data import TestData
    from bayes_dnlr.inference.lsq.identify import fit_test
    from bayes_dnlr.model import simulate

    rate = 5e-3
    t = np.linspace(0.0, 1.9 / rate, 2000)
    e = rate * t
    clean = simulate(t, e, TABLE3)
    cfg = parse_config({"name": "cov", "fit": {"multistart": 0},
                        "data": {"file": "x.csv", "columns": {"time": "t", "strain": "e", "stress": "s"},
                                 "observable": "stress", "strain_input": "measured"}})
    est, sd = [], []
    t0 = time.perf_counter()
    for i in range(n_rep):
        y = clean + np.random.default_rng(10_000 + i).normal(0.0, 0.3, t.size)
        test = TestData(path=Path("x.csv"), sha256="", time=t, strain=e, strain_input=e, stress=y,
                        nominal_strain=np.expm1(e), nominal_stress=None, window=np.ones(t.size, bool),
                        relaxation_start=None, strain_rate=rate, observable="stress")
        r = fit_test(cfg, test)
        est.append([r.estimate[k] for k in TABLE3])
        sd.append([r.sd[k] for k in TABLE3])
    summary("exact strain input, stress noise 0.3 MPa, sigma0 from the residuals", np.array(est),
            np.array(sd), TABLE3, time.perf_counter() - t0)


def pipeline(n_rep: int, config: Path, strain_input: str) -> None:
    from bayes_dnlr.config import parse_config
    from bayes_dnlr.data import load_test
    from bayes_dnlr.inference.lsq.identify import fit_test
    from bayes_dnlr.workflows.simulate import simulate_test

    raw = yaml.safe_load(config.read_text())
    truth = raw["truth"]["params"]
    res = {"known": ([], []), "residuals": ([], [])}
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(n_rep):
            r = dict(raw)
            r["truth"] = {**raw["truth"], "seed": 20_000 + i}
            r["data"] = {**raw["data"], "file": "data.csv", "strain_input": strain_input}
            r["fit"] = {**raw.get("fit", {}), "multistart": 0}
            r["output"] = {"dir": tmp}
            cfg = parse_config(r, source=Path(tmp) / "config.yaml")
            simulate_test(cfg, overwrite=True)
            test = load_test(cfg)
            for key, sigma in (("known", raw["truth"]["noise"]["stress_sd"]), ("residuals", "residuals")):
                c = cfg.model_copy(deep=True)
                c.noise.sigma0 = sigma
                f = fit_test(c, test)
                res[key][0].append([f.estimate[k] for k in truth])
                res[key][1].append([f.sd[k] for k in truth])
    wall = time.perf_counter() - t0
    for key, (est, sd) in res.items():
        summary(f"pipeline ({config.parent.name}: simulate_test -> load_test, strain_input {strain_input}), "
                f"sigma0 {key}", np.array(est), np.array(sd), truth, wall)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--replicates", type=int, default=300)
    p.add_argument("--config", type=Path, default=REPO / "runs" / "hdpe-a-5e-3" / "config.yaml")
    p.add_argument("--skip-pipeline", action="store_true")
    args = p.parse_args(argv)
    exact_input(args.replicates)
    if not args.skip_pipeline:
        for si in ("smoothed", "measured"):
            pipeline(args.replicates, args.config, si)
    return 0


if __name__ == "__main__":
    sys.exit(main())
