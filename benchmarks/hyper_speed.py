"""The cost of the discrepancy's hyperparameters in ``fit``, and what they give: per case the warm
wall time of ``fit`` with the default config (kernel auto, target generalized) beside the same fit
with ``discrepancy: none``, the likelihood evaluations of the hyperparameter search, and E ± sd of
the discrepancy analysis; ``--save`` writes them, ``--compare`` prints the change of E and of its sd
in sd against a saved file (an algorithm change must keep both within its tolerance).

    .venv/bin/python benchmarks/hyper_speed.py [--cases shipped etfe rhdpe] [--save F] [--compare F]

Cases: the shipped examples of runs/ (``make demo``'s first), the three real ETFE specimens of
../shared/data/real on windows 0.1, 0.3 and the whole curve, the real rHDPE curve with both toe
remedies at 0.07 (skipped when ../shared/data/real is absent). Each fit runs twice in one process;
the CPU time (process_time, all threads) of the second (warm: numba caches and imports loaded) is
printed, as the machine is shared. The reference job (../shared/tools/refjob.py, or
$BAYES_DNLR_REFJOB) is timed in the same run.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml
from reference_job import seconds as reference_job  # benchmarks/ is the script's folder

REPO = Path(__file__).resolve().parents[1]
REAL = Path(os.environ.get("BAYES_DNLR_REAL_DATA", REPO.parent / "shared" / "data" / "real"))
SHIPPED = ["hdpe-a-5e-3", "hdpe-a-1e-2", "hdpe-a-2.5e-3", "hdpe-b-relax-5e-3", "bluehill-like",
           "zwick-like"]


def real_cases(tmp: Path, which: list[str]) -> list[tuple[str, Path]]:
    out = []
    if "etfe" in which and (REAL / "ETFE_MD_CSR_0p1pct_per_s_T40C_3specimens.csv").is_file():
        sys.path.insert(0, str(REPO / "benchmarks"))
        from real_etfe import FILE, specimens

        for k, (t, e, s) in enumerate(specimens(REAL / FILE)):
            np.savetxt(tmp / f"etfe-{k}.csv", np.column_stack([t, e, s]), delimiter=",",
                       header="t_s,eps11,sigma_MPa", comments="", fmt="%.10g")
            for w in ("0.1", "0.3", "whole"):
                run = tmp / f"etfe{k}-{w}"
                run.mkdir()
                raw = {"name": run.name, "data": {"file": f"../etfe-{k}.csv", "observable": "stress",
                       "columns": {"time": "t_s", "eps11": "eps11", "stress": "sigma_MPa"}},
                       "noise": {"sigma0": "residuals"}}
                if w != "whole":
                    raw["data"]["window"] = {"strain_max": float(w)}
                (run / "config.yaml").write_text(yaml.safe_dump(raw))
                out.append((run.name, run / "config.yaml"))
    if "rhdpe" in which and (REAL / "rHDPE_Resin19_specimen3_tensile_50mm_per_min.csv").is_file():
        sys.path.insert(0, str(REPO / "benchmarks"))
        from real_rhdpe import FILE, REMEDIES

        for remedy, extra in REMEDIES.items():
            run = tmp / f"rhdpe-{remedy}"
            run.mkdir()
            raw = {"name": run.name,
                   "data": {"file": str(REAL / FILE), "columns": {"time": 2, "force": 4, "strain": 6},
                            "strain_unit": "percent", "strain_measure": "nominal", "area0": 37.2,
                            "window": {"strain_max": 0.07}, **extra},
                   "noise": {"sigma0": "residuals"}, "fit": {"multistart": 2}}
            (run / "config.yaml").write_text(yaml.safe_dump(raw))
            out.append((run.name, run / "config.yaml"))
    return out


def measure(path: Path) -> dict:
    from bayes_dnlr.config import load_config
    from bayes_dnlr.runs.fit import fit

    cfg = load_config(path)
    white = cfg.model_copy(deep=True)
    white.noise.discrepancy = "none"
    fit(cfg, write=False)
    t0 = time.process_time()
    r = fit(cfg, write=False).only
    t_default = time.process_time() - t0
    fit(white, write=False)
    t0 = time.process_time()
    fit(white, write=False)
    t_white = time.process_time() - t0
    d = r.discrepancy
    return {"n": r.n_points, "t_default": t_default, "t_white": t_white, "E": d["estimate"]["E"],
            "sd": d["sd"]["E"], "evaluations": d["ml_evaluations"], "lr": d["likelihood_ratio"],
            "evidence": d["evidence"], "weights": d["kernel_choice"]["weights"],
            "hyper": d["hyperparameters"], "search": d.get("hyper_search", "")}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cases", nargs="+", default=["shipped", "etfe", "rhdpe"])
    p.add_argument("--save", type=Path)
    p.add_argument("--compare", type=Path)
    args = p.parse_args(argv)
    ref = reference_job()
    print(f"reference job {ref if ref is None else f'{ref:.3f} s'}; load {os.getloadavg()}")
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        cases = ([(k, REPO / "runs" / k / "config.yaml") for k in SHIPPED] if "shipped" in args.cases
                 else []) + real_cases(Path(tmp), args.cases)
        old = json.loads(args.compare.read_text()) if args.compare else {}
        print(f"{'case':<26}{'n':>6}{'default s':>10}{'none s':>8}{'ratio':>7}{'evals':>6}"
              f"{'E':>10}{'sd':>8}{'2ΔlogL':>9}  weights exp/m32" + ("   ΔE/sd  Δsd/sd" if old else ""))
        for name, path in cases:
            m = measure(path)
            results[name] = m
            line = (f"{name:<26}{m['n']:>6}{m['t_default']:>10.3f}{m['t_white']:>8.3f}"
                    f"{m['t_default'] / m['t_white']:>7.2f}{m['evaluations']:>6}{m['E']:>10.2f}"
                    f"{m['sd']:>8.2f}{m['lr']:>9.2f}  "
                    + "/".join(f"{m['weights'].get(k, 0):.2f}" for k in ("exp", "matern32")))
            if name in old:
                o = old[name]
                line += f"   {(m['E'] - o['E']) / o['sd']:+.4f} {(m['sd'] - o['sd']) / o['sd']:+.4f}"
            print(line, flush=True)
    tot_d = sum(m["t_default"] for m in results.values())
    tot_w = sum(m["t_white"] for m in results.values())
    print(f"total: default {tot_d:.2f} s, none {tot_w:.2f} s, ratio {tot_d / tot_w:.2f}"
          + (f"; reference job {ref:.3f} s" if ref else "") + f"; load {os.getloadavg()}")
    if args.save:
        args.save.write_text(json.dumps(results, indent=1, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
