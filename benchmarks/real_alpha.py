"""E with the spectrum's exponent alpha sampled against alpha = ½ (eq. 12) on the real curves of
../shared/data/real (not part of the project; see its README): the three ETFE specimens (whole
curve) and the rHDPE curve (up to strain 0.07, G fixed at 0, with each of its two toe remedies).

    .venv/bin/python benchmarks/real_alpha.py [--jobs 2] [--fit-only] [--set KEY=YAML ...]

Each curve goes through ``fit`` and ``sample`` from a config in a temporary folder (the data are
read where they lie, never copied into the project), once with the default (alpha = ½, eq. 12)
and once with ``parameters.alpha`` sampled from the prior the docs propose (config.ALPHA_PRIOR).
Prints E's posterior mean ± sd and 90 % HDI under both, the shift of E in sd, alpha's posterior
and the posterior correlation of E and alpha, the sampling steps and time. Exits cleanly when
../shared/data/real is absent (BAYES_DNLR_REAL_DATA may point elsewhere, as for the tests).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import yaml

from bayes_dnlr.config import ALPHA_PRIOR

REAL = Path(os.environ.get("BAYES_DNLR_REAL_DATA",
                           Path(__file__).resolve().parents[2] / "shared" / "data" / "real"))
ETFE = REAL / "ETFE_MD_CSR_0p1pct_per_s_T40C_3specimens.csv"
RHDPE = REAL / "rHDPE_Resin19_specimen3_tensile_50mm_per_min.csv"
ALPHA = {"alpha free": ALPHA_PRIOR, "alpha = 1/2": None}     # None: the key left out (the default)


def curves() -> dict[str, dict]:
    """name -> the data: and parameters: sections of each real curve's config."""
    out = {}
    for k in (1, 2, 3):
        out[f"ETFE {k}"] = ({"file": str(ETFE), "specimen": k,
                             "columns": {"time": 1, "eps11": 8, "stress": 10},
                             "observable": "stress"}, {})
    rhdpe = {"file": str(RHDPE), "columns": {"time": 2, "force": 4, "strain": 6},
             "strain_unit": "percent", "strain_measure": "nominal", "area0": 37.2,
             "window": {"strain_max": 0.07}}
    out["rHDPE ramp-from-zero"] = ({**rhdpe, "initial_state": "ramp-from-zero"}, {"G": {"value": 0.0}})
    out["rHDPE toe compensate"] = ({**rhdpe, "toe": "compensate"}, {"G": {"value": 0.0}})
    return out


def one_run(args: tuple) -> dict:
    folder, name, alpha, fit_only, overrides = args
    from bayes_dnlr.config import load_config
    from bayes_dnlr.errors import BayesDnlrError
    from bayes_dnlr.runs.fit import fit
    from bayes_dnlr.runs.sample import sample

    data, params = curves()[name]
    params = dict(params)
    if ALPHA[alpha] is not None:
        params["alpha"] = ALPHA[alpha]
    slug = name.replace(" ", "-").replace("=", "") + ("-half" if ALPHA[alpha] is None else "-free")
    run = Path(folder) / slug
    run.mkdir()
    raw = {"name": slug, "data": data, "parameters": params, "noise": {"sigma0": "residuals"}}
    for key, value in overrides:
        d = raw
        *head, last = key.split(".")
        for k in head:
            d = d.setdefault(k, {})
        d[last] = value
    (run / "config.yaml").write_text(yaml.safe_dump(raw))
    out = {"name": name, "alpha": alpha}
    t0 = time.perf_counter()
    try:
        cfg = load_config(run / "config.yaml")
        r = fit(cfg)
        src = r.discrepancy if r.discrepancy and r.discrepancy.get("estimate") else None
        est, sd = (src or {}).get("estimate", r.estimate), (src or {}).get("sd", r.sd)
        out.update(fit_E=est["E"], fit_sd=sd["E"], fit_alpha=est.get("alpha"),
                   fit_alpha_sd=sd.get("alpha"), kernel=(r.discrepancy or {}).get("kernel"))
        if not fit_only:
            s = sample(cfg, progress=False).summary
            p = s["posterior"]
            out.update(mean=p["E"]["mean"], sd=p["E"]["sd"], hdi=p["E"]["hdi_90"], steps=s["steps"],
                       converged=s["stop_reason"] == "converged", loop_s=s["wall_time_s"])
            if "alpha" in p:
                import h5netcdf

                with h5netcdf.File(cfg.run_dir / "posterior.nc", "r") as f:
                    e = np.asarray(f["posterior"]["E"][...]).ravel()
                    a = np.asarray(f["posterior"]["alpha"][...]).ravel()
                out.update(alpha_mean=p["alpha"]["mean"], alpha_sd=p["alpha"]["sd"],
                           alpha_hdi=p["alpha"]["hdi_90"], corr=float(np.corrcoef(e, a)[0, 1]),
                           slope=float(np.polyfit(a, e, 1)[0]))
    except BayesDnlrError as err:
        out["error"] = str(err).splitlines()[0][:200]
    out["wall_s"] = time.perf_counter() - t0
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--fit-only", action="store_true")
    ap.add_argument("--curves", nargs="+", default=None, help="names as printed (default: all)")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=YAML",
                    help="a config key for every run, e.g. 'noise.discrepancy=none'")
    args = ap.parse_args(argv)
    if not (ETFE.is_file() and RHDPE.is_file()):
        print(f"{REAL} not found: the real data live outside the project; nothing to do")
        return 0
    overrides = [(t.partition("=")[0], yaml.safe_load(t.partition("=")[2])) for t in args.set]
    names = args.curves or list(curves())
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp, ProcessPoolExecutor(args.jobs) as pool:
        jobs = [(tmp, n, a, args.fit_only, overrides) for n in names for a in ALPHA]
        results = list(pool.map(one_run, jobs))
    key, sdk = ("fit_E", "fit_sd") if args.fit_only else ("mean", "sd")
    print(f"E in MPa ({'linearized' if args.fit_only else 'posterior mean ± sd [90 % HDI]'}); "
          f"overrides {args.set or 'none'}; {time.perf_counter() - t0:.0f} s, {args.jobs} jobs")
    for n in names:
        rows = {r["alpha"]: r for r in results if r["name"] == n}
        free, half = rows["alpha free"], rows["alpha = 1/2"]
        if "error" in free or "error" in half:
            print(f"{n}: failed: {free.get('error') or half.get('error')}")
            continue
        shift = (free[key] - half[key]) / half[sdk]
        line = (f"{n:<22} alpha = 1/2: {half[key]:7.0f} ± {half[sdk]:<5.0f} | alpha free: "
                f"{free[key]:7.0f} ± {free[sdk]:<5.0f} (sd x{free[sdk] / half[sdk]:.1f}; shift "
                f"{shift:+.1f} sd of alpha = 1/2)")
        if args.fit_only:
            line += f"; alpha {free['fit_alpha']:.3f} ± {free['fit_alpha_sd']:.3f}"
        else:
            line += (f"; alpha {free['alpha_mean']:.3f} ± {free['alpha_sd']:.3f} "
                     f"[{free['alpha_hdi'][0]:.3f}, {free['alpha_hdi'][1]:.3f}], corr(E, alpha) "
                     f"{free['corr']:+.3f}, dE/dalpha {free['slope']:.0f} MPa; steps "
                     f"{half['steps']} -> {free['steps']}, {half['loop_s']:.0f} -> "
                     f"{free['loop_s']:.0f} s")
        print(line + f"; kernel {free.get('kernel')}/{half.get('kernel')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
