"""The real rHDPE curve of ../shared/data/real (not part of the project; see its README): E under the
two remedies the data layer offers for its cropped toe, ``initial_state: ramp-from-zero`` and
``toe: compensate``, which should agree within their intervals.

    .venv/bin/python benchmarks/real_rhdpe.py [--windows 0.05 0.07 0.105] [--targets default l2 white]
                                              [--fit-only] [--jobs 2]

The machine export is read as it is, with the config of tests/runs/test_real_data.py (force and
crosshead strain, area 37.2 mm²), G free, the window up to the given nominal strain. Each case goes
through the ordinary pipeline in a temporary folder (fit, then sample unless --fit-only) and prints
E (posterior mean ± sd and 90 % HDI, or the linearized estimate ± sd), the difference between the
two remedies in combined sd, the kernel weights and the hyperparameters. Exits cleanly when
../shared/data/real is absent.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import yaml

REPO = Path(__file__).resolve().parents[1]
REAL = Path(os.environ.get("BAYES_DNLR_REAL_DATA", REPO.parent / "shared" / "data" / "real"))
FILE = "rHDPE_Resin19_specimen3_tensile_50mm_per_min.csv"
REMEDIES = {"ramp-from-zero": {"initial_state": "ramp-from-zero"}, "compensate": {"toe": "compensate"}}
TARGETS = {"default": "default config (model discrepancy, target generalized)",
           "l2": "target l2 (orthogonal discrepancy, projection offsets)", "white": "discrepancy: none"}


def one_run(args: tuple) -> dict:
    folder, remedy, window, target, fit_only = args
    from bayes_dnlr.config import load_config
    from bayes_dnlr.errors import BayesDnlrError
    from bayes_dnlr.runs.fit import fit
    from bayes_dnlr.runs.sample import sample

    run = Path(folder) / f"rhdpe-{remedy}-{window}-{target}"
    run.mkdir()
    raw = {"name": run.name,
           "data": {"file": str(REAL / FILE), "columns": {"time": 2, "force": 4, "strain": 6},
                    "strain_unit": "percent", "strain_measure": "nominal", "area0": 37.2,
                    "window": {"strain_max": float(window)}, **REMEDIES[remedy]},
           "noise": {"sigma0": "residuals"}, "fit": {"multistart": 2}, "sampler": {"seed": 1}}
    if target == "white":
        raw["noise"]["discrepancy"] = "none"
    elif target == "l2":
        raw["noise"]["discrepancy"] = {"target": "l2"}
    (run / "config.yaml").write_text(yaml.safe_dump(raw))
    cfg = load_config(run / "config.yaml")
    out = {"remedy": remedy, "window": window, "target": target}
    t0 = time.perf_counter()
    try:
        r = fit(cfg)
        d = r.discrepancy if target != "white" else None
        src = d or {}
        out.update(fit_E=src.get("estimate", r.estimate)["E"], fit_sd=src.get("sd", r.sd)["E"],
                   hyper=src.get("hyperparameters"), lr=src.get("likelihood_ratio"),
                   weights=(src.get("kernel_choice") or {}).get("weights"))
        if not fit_only:
            s = sample(cfg, progress=False).summary
            p = s["posterior"]["E"]
            out.update(mean=p["mean"], sd=p["sd"], hdi=p["hdi_90"], steps=s["steps"], loop_s=s["wall_time_s"])
    except BayesDnlrError as err:
        out["error"] = str(err).splitlines()[0][:160]
    out["wall_s"] = time.perf_counter() - t0
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--windows", nargs="+", default=["0.05", "0.07", "0.105"])
    p.add_argument("--targets", nargs="+", default=["default", "white"], choices=list(TARGETS))
    p.add_argument("--fit-only", action="store_true")
    p.add_argument("--jobs", type=int, default=2)
    args = p.parse_args(argv)
    if not (REAL / FILE).is_file():
        print(f"{REAL / FILE} not found: the real data live outside the project; nothing to do")
        return 0
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        jobs = [(tmp, rem, w, t, args.fit_only)
                for t in args.targets for w in args.windows for rem in REMEDIES]
        with ProcessPoolExecutor(args.jobs) as pool:
            results = list(pool.map(one_run, jobs))
    mean_key, sd_key = ("fit_E", "fit_sd") if args.fit_only else ("mean", "sd")
    print(f"rHDPE ({FILE}), E in MPa, {'linearized' if args.fit_only else 'posterior'}; "
          f"{len(results)} runs in {time.perf_counter() - t0:.0f} s ({args.jobs} jobs)")
    for t in args.targets:
        print(f"\n{t}: {TARGETS[t]}")
        for w in args.windows:
            rows = {r["remedy"]: r for r in results if r["target"] == t and r["window"] == w}
            cells = []
            for rem in REMEDIES:
                r = rows[rem]
                if "error" in r:
                    cells.append(f"{rem}: failed ({r['error']})")
                    continue
                hdi = "" if args.fit_only else f" [{r['hdi'][0]:.0f}, {r['hdi'][1]:.0f}]"
                wts = r.get("weights") or {}
                cells.append(f"{rem}: {r[mean_key]:.0f} ± {r[sd_key]:.0f}{hdi}"
                             + (" (" + ", ".join(f"{k} {100 * v:.0f} %" for k, v in wts.items()) + ")"
                                if len(wts) > 1 else ""))
            line = f"  window ε ≤ {w}: " + "; ".join(cells)
            a, b = rows["ramp-from-zero"], rows["compensate"]
            if "error" not in a and "error" not in b:
                diff = (a[mean_key] - b[mean_key]) / math.hypot(a[sd_key], b[sd_key])
                line += f"; difference {diff:+.2f} combined sd"
            print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
