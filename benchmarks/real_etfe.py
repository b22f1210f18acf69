"""The three real ETFE specimens of ../shared/data/real (not part of the project; see its README):
the posterior of E under the default config (model discrepancy) and under the white likelihood, on
windows up to strain 0.1, 0.3 and the whole curve.

    .venv/bin/python benchmarks/real_etfe.py [--windows 0.1 0.3 whole] [--likelihoods default white]
                                             [--fit-only] [--jobs 2]

Each specimen (time, Hencky axial strain SOI, true stress) goes to a temporary CSV + config (never
into the project) and through the ordinary pipeline (fit, then sample unless --fit-only). Prints:

- E per specimen and window: posterior mean ± sd and 90 % HDI (or the linearized estimate ± sd with
  --fit-only), for each likelihood;
- the ratio of the between-specimen sd of E to the mean within-specimen posterior sd (about
  5 with the white likelihood; aim <= 2);
- whether each specimen's 90 % interval contains the other specimens' estimates;
- the discrepancy's hyperparameters and the likelihood ratio against the white model.

Exits cleanly with a message when ../shared/data/real is absent (a user's clone has no ../shared).
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

REPO = Path(__file__).resolve().parents[1]
REAL = Path(os.environ.get("BAYES_DNLR_REAL_DATA", REPO.parent / "shared" / "data" / "real"))
FILE = "ETFE_MD_CSR_0p1pct_per_s_T40C_3specimens.csv"
# per specimen k the columns are 15 k + offset (README): time, Hencky axial strain (SOI), true stress
TIME, HENCKY_SOI, TRUE_STRESS_SOI = 0, 7, 9
LIKELIHOODS = {"default": "model discrepancy, default config (kernel auto, target generalized)",
               "l2": "model discrepancy, target l2 (orthogonal discrepancy, projection offsets)",
               "exp": "exp kernel, maximum-likelihood hyperparameters", "white": "discrepancy: none",
               "matern32": "matern32 kernel, maximum-likelihood hyperparameters",
               "matern32-pinned": "matern32 kernel, pinned start (delta = delta' = 0 at the first sample)",
               "exp-pinned": "exp kernel, pinned start (delta = 0 at the first sample)",
               "matern32-2-55": "matern32 kernel, amplitude 2 MPa and length 55 s fixed"}


def specimens(path: Path) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """(time, strain, stress) of each specimen, padding rows dropped."""
    a = np.genfromtxt(path, delimiter=",")
    out = []
    for k in range(a.shape[1] // 15):
        t, e, s = (a[:, 15 * k + c] for c in (TIME, HENCKY_SOI, TRUE_STRESS_SOI))
        keep = np.isfinite(t) & np.isfinite(e) & np.isfinite(s)
        out.append((t[keep], e[keep], s[keep]))
    return out


def one_run(args: tuple) -> dict:
    """fit (and sample) one specimen, window and likelihood; returns E's numbers."""
    folder, k, window, likelihood, fit_only = args
    from bayes_dnlr.config import load_config
    from bayes_dnlr.errors import BayesDnlrError
    from bayes_dnlr.runs.fit import fit
    from bayes_dnlr.runs.sample import sample

    name = f"etfe{k}-{window}-{likelihood}"
    run = Path(folder) / name
    run.mkdir()
    raw = {"name": name,
           "data": {"file": f"../etfe-{k}.csv", "columns": {"time": "t_s", "eps11": "eps11",
                                                             "stress": "sigma_MPa"},
                    "observable": "stress"},
           "noise": {"sigma0": "residuals"}, "sampler": {"seed": k + 1}}
    if window != "whole":
        raw["data"]["window"] = {"strain_max": float(window)}
    if likelihood == "white":
        raw["noise"]["discrepancy"] = "none"
    elif likelihood == "l2":
        raw["noise"]["discrepancy"] = {"target": "l2"}
    elif likelihood in ("matern32", "exp"):
        raw["noise"]["discrepancy"] = {"kernel": likelihood}
    elif likelihood in ("matern32-pinned", "exp-pinned"):
        raw["noise"]["discrepancy"] = {"kernel": likelihood.split("-")[0], "start": "pinned"}
    elif likelihood == "matern32-2-55":      # the brief's first look: a = 2 MPa, l = 55 s held fixed
        raw["noise"]["discrepancy"] = {"kernel": "matern32", "amplitude": {"value": 2.0},
                                       "length": {"value": 55.0}}
    (run / "config.yaml").write_text(yaml.safe_dump(raw))
    cfg = load_config(run / "config.yaml")
    out = {"k": k, "window": window, "likelihood": likelihood}
    t0 = time.perf_counter()
    try:
        r = fit(cfg).only
        d = r.discrepancy
        src = d if (d and likelihood != "white") else None
        est = (src or {}).get("estimate", r.estimate)["E"]
        sd = (src or {}).get("sd", r.sd)["E"]
        out.update(fit_E=est, fit_sd=sd, lr=(d or {}).get("likelihood_ratio"),
                   hyper=(d or {}).get("hyperparameters"), evidence=(d or {}).get("evidence"),
                   kernel=(d or {}).get("kernel"),
                   choice=((d or {}).get("kernel_choice") or {}).get("reason"),
                   widening=((d or {}).get("projection") or {}).get("widening", {}).get("E"))
        if not fit_only:
            s = sample(cfg, progress=False).summary
            p = s["posterior"]["E"]
            out.update(mean=p["mean"], sd=p["sd"], hdi=p["hdi_90"], steps=s["steps"],
                       converged=s["stop_reason"] == "converged", loop_s=s["wall_time_s"],
                       amplitude=(s["posterior"].get("disc_amplitude") or {}).get("mean"),
                       length=(s["posterior"].get("disc_length") or {}).get("mean"))
            c = s.get("checks") or {}
            mf = c.get("model_form") or {}
            out.update(coverage=(c.get("predictive_coverage") or {}).get("overall"),
                       segments={k: v["share"] for k, v in
                                 ((c.get("predictive_coverage") or {}).get("segments") or {}).items()},
                       adequate=c.get("adequate"), trust=c.get("trust_interval"),
                       score_z=mf.get("z"), score_shift_sd=mf.get("E_shift_sd"),
                       bounds=[b["parameter"] for b in c.get("bound_limited") or []],
                       verdict=c.get("verdict"))
    except BayesDnlrError as err:
        out["error"] = str(err).splitlines()[0][:160]
    out["wall_s"] = time.perf_counter() - t0
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--windows", nargs="+", default=["0.1", "0.3", "whole"])
    p.add_argument("--likelihoods", nargs="+", default=["default", "white"], choices=list(LIKELIHOODS))
    p.add_argument("--fit-only", action="store_true", help="linearized intervals only (fast)")
    p.add_argument("--jobs", type=int, default=2)
    args = p.parse_args(argv)
    path = REAL / FILE
    if not path.is_file():
        print(f"{path} not found: the real data live outside the project (../shared/data/real); "
              "nothing to do")
        return 0
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        for k, (t, e, s) in enumerate(specimens(path)):
            np.savetxt(Path(tmp) / f"etfe-{k}.csv", np.column_stack([t, e, s]), delimiter=",",
                       header="t_s,eps11,sigma_MPa", comments="", fmt="%.10g")
        jobs = [(tmp, k, w, lik, args.fit_only) for lik in args.likelihoods for w in args.windows
                for k in range(3)]
        with ProcessPoolExecutor(args.jobs) as pool:
            results = list(pool.map(one_run, jobs))
    wall = time.perf_counter() - t0
    mean_key, sd_key = ("fit_E", "fit_sd") if args.fit_only else ("mean", "sd")
    what = "linearized estimate ± sd" if args.fit_only else "posterior mean ± sd [90 % HDI]"
    print(f"ETFE, machine direction, 40 °C (README: {FILE}); E in MPa, {what}; "
          f"{len(results)} runs in {wall:.0f} s ({args.jobs} jobs)")
    for lik in args.likelihoods:
        print(f"\nlikelihood: {lik} ({LIKELIHOODS[lik]})")
        print(f"  {'specimen':<9}" + "".join(f"{'window ' + w:>34}" for w in args.windows))
        for k in range(3):
            cells = []
            for w in args.windows:
                r = next(x for x in results if x["k"] == k and x["window"] == w and x["likelihood"] == lik)
                if "error" in r:
                    cells.append(f"{'failed':>34}")
                elif args.fit_only:
                    cells.append(f"{r[mean_key]:>22.0f} ± {r[sd_key]:<9.0f}")
                else:
                    cells.append(f"{r['mean']:>12.0f} ± {r['sd']:<5.0f}[{r['hdi'][0]:.0f}, {r['hdi'][1]:.0f}]"
                                 .rjust(34))
            print(f"  {k:<9}" + "".join(cells))
        for w in args.windows:
            rows = [x for x in results if x["window"] == w and x["likelihood"] == lik and "error" not in x]
            if len(rows) < 2:
                continue
            est = np.array([x[mean_key] for x in rows])
            sds = np.array([x[sd_key] for x in rows])
            ratio = est.std(ddof=1) / sds.mean()
            line = (f"  window {w}: between-specimen sd {est.std(ddof=1):.0f}, mean within sd "
                    f"{sds.mean():.0f}, ratio {ratio:.2f}")
            if not args.fit_only:
                holds = [all(x["hdi"][0] <= y["mean"] <= x["hdi"][1] for y in rows if y is not x)
                         for x in rows]
                line += f"; each 90 % HDI holds the others' means: {holds}"
            print(line)
        if not args.fit_only:
            for r in results:
                if r["likelihood"] == lik and "error" not in r and r.get("verdict"):
                    seg = ", ".join(f"{k} {100 * v:.0f}" for k, v in r["segments"].items() if v is not None)
                    z = "" if r["score_z"] is None else (f"; model-form score z {r['score_z']:+.1f} "
                                                         f"(E {r['score_shift_sd'] or 0:+.1f} sd)")
                    print(f"  checks, specimen {r['k']} window {r['window']}: predictive coverage "
                          f"{100 * r['coverage']:.0f} % ({seg}); adequate {r['adequate']}, trust "
                          f"{r['trust']}; piled on a bound: {r['bounds'] or 'none'}{z}")
                    print(f"    verdict: {r['verdict']}")
        for r in results:
            if r["likelihood"] == lik and "error" in r:
                print(f"  specimen {r['k']}, window {r['window']}: {r['error']}")
        if lik != "white":
            for r in results:
                if r["likelihood"] == lik and "error" not in r and r.get("hyper"):
                    h = r["hyper"]
                    post = ("" if args.fit_only else
                            f"; posterior amplitude {r.get('amplitude') or 0:.3g} MPa, length "
                            f"{r.get('length') or float('nan'):.3g} s, {r['steps']} steps, "
                            f"{r['loop_s']:.1f} s")
                    print(f"  specimen {r['k']} window {r['window']}: {r['kernel']}; "
                          f"2 Δ log L = {r['lr']:.4g}; ML "
                          f"sigma0 {h['sigma0']:.3g}, amplitude {h['amplitude']:.3g} MPa, length "
                          f"{h['length']:.3g} s{post}")
                    if r.get("choice"):
                        print(f"    kernel auto: {r['choice']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
