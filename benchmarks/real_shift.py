"""The stress shift on the real ETFE film (not part of the project; ../shared/data/real and the
film's other exports, scratch/real): each test fitted alone, without a shift and with the Eyring
shift driven by each choice of stress (model.shift.driving), white least squares.

    .venv/bin/python benchmarks/real_shift.py [--variants none stress peak overstress]
        [--tests ramps cycles relax] [--wide] [--jobs 2]

Tests: the three 40 °C constant-rate ramps (windows: up to 4 % strain, and the whole curve to
~65 %), the six 20 °C loading-unloading cycles (the whole history) and the three 20 °C ramp-then-
hold relaxations (the whole test). Each test goes to a temporary config (never into the project)
and through the ordinary ``fit`` with the default priors, but for the ramps G's is widened to
[0, 500] MPa and tau_max's to [0.01, 1e7] s (a stress-shifted fit of their start wants G near
100 MPa); the relaxations keep G's default box, whose bound holds G where the ramp to 0.8 % cannot
tell it from tau_max.

Prints per test and variant: the residual rms over the window and over its part up to 4 % strain,
sigma_s ± sd, E, G, tau_max, E(t) at 0.5, 2, 20 and 100 s (the σ -> 0 limit: the reference spectrum,
model/modulus.py), and for the cycles the mean model - data where the film unloads near zero
stress (data stress below 1 MPa, strain falling): the stress-blind model's "−4 MPa".

Exits cleanly with a message when the real data are absent.
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
EXPORTS = Path(os.environ.get("BAYES_DNLR_REAL_EXPORTS", REPO.parent / "scratch" / "real"))
RAMPS = REAL / "ETFE_MD_CSR_0p1pct_per_s_T40C_3specimens.csv"
CYCLES = EXPORTS / "OUTRaw_MD_CYC_CSR_01_T20.csv"
RELAX = EXPORTS / "OUTRaw_MD_Rel_9MPa_T20.csv"
SMALL = 0.04                # "up to 4 % strain"
TIMES = (0.5, 2.0, 20.0, 100.0)  # s, E(t)
UNLOADED = 1.0              # MPa: the film reads about 0 below this on its unloadings
PRIORS = {"G": {"prior": "uniform", "low": 0.0, "high": 500.0},
          "tau_max": {"prior": "log-uniform", "low": 0.01, "high": 1.0e7}}


def ramp_files(folder: Path) -> list[Path]:
    """Each 40 °C specimen as (time, Hencky axial strain SOI, true stress) in its own CSV."""
    a = np.genfromtxt(RAMPS, delimiter=",")
    out = []
    for k in range(a.shape[1] // 15):
        t, e, s = (a[:, 15 * k + c] for c in (0, 7, 9))
        keep = np.isfinite(t) & np.isfinite(e) & np.isfinite(s)
        t, e, s = t[keep], e[keep], s[keep]
        keep = np.concatenate([[True], np.diff(t) > 0])     # trailing padding repeats the time
        path = folder / f"ramp-{k + 1}.csv"
        np.savetxt(path, np.column_stack([t[keep], e[keep], s[keep]]), delimiter=",",
                   header="t_s,eps11,sigma_MPa", comments="", fmt="%.10g")
        out.append(path)
    return out


def data_section(kind: str, source: Path, specimen: int, window: float | None) -> dict:
    if kind == "ramps":
        d = {"file": str(source), "columns": {"time": "t_s", "eps11": "eps11", "stress": "sigma_MPa"},
             "observable": "stress", "temperature": 40.0}
        if window is not None:
            d["window"] = {"strain_max": window}
        return d
    if kind == "cycles":
        return {"file": str(source), "specimen": specimen, "specimen_columns": 8,
                "columns": {"time": 1, "strain": 2, "stress": 4}, "strain_measure": "nominal",
                "strain_unit": "fraction", "observable": "stress", "stress_measure": "engineering",
                "repeated_time": "drop", "temperature": 20.0}
    return {"file": str(source), "specimen": specimen, "specimen_columns": 9,
            "columns": {"time": 1, "strain": 2, "stress": 8}, "strain_measure": "nominal",
            "strain_unit": "fraction", "observable": "stress", "relaxation_start": "auto",
            "temperature": 20.0}


def one_fit(job: tuple) -> dict:
    folder, kind, source, specimen, window, variant, wide = job
    from bayes_dnlr.config import load_config
    from bayes_dnlr.errors import BayesDnlrError
    from bayes_dnlr.model.modulus import relaxation_modulus
    from bayes_dnlr.runs.fit import fit

    name = f"{kind}-{specimen}-{window or 'whole'}-{variant}".replace(".", "p")
    run = Path(folder) / name
    run.mkdir()
    raw = {"name": name, "data": data_section(kind, Path(source), specimen, window),
           "noise": {"sigma0": "residuals", "discrepancy": "none"},
           "parameters": dict(PRIORS) if kind == "ramps" or wide else {}}
    if variant != "none":
        raw["model"] = {"shift": {"stress": "eyring", "driving": variant}}
    (run / "config.yaml").write_text(yaml.safe_dump(raw))
    out = {"kind": kind, "specimen": specimen, "window": window, "variant": variant}
    t0 = time.perf_counter()
    try:
        r = fit(load_config(run / "config.yaml")).only
    except BayesDnlrError as err:
        out["error"] = str(err).splitlines()[0][:160]
        return out
    res = np.asarray(r.residuals)
    strain = np.asarray(r.strain)
    small = strain <= SMALL
    p = r.estimate
    out.update(rms=float(np.sqrt(np.mean(res ** 2))),
               rms_small=float(np.sqrt(np.mean(res[small] ** 2))) if small.any() else float("nan"),
               E=p["E"], G=p["G"], tau_max=p["tau_max"], sigma_s=p.get("sigma_s"),
               sigma_s_sd=r.sd.get("sigma_s"), wall_s=time.perf_counter() - t0,
               modulus=[float(v) for v in relaxation_modulus(np.array(TIMES), p["E"], p["G"],
                                                             p["tau_max"])])
    if kind == "cycles":
        data = np.asarray(r.fitted) + res
        falling = np.gradient(strain) < 0
        at_zero = (data < UNLOADED) & falling
        out["unload"] = float(np.mean(-res[at_zero])) if at_zero.any() else float("nan")
        out["unload_n"] = int(at_zero.sum())
    return out


def _fmt(x: float | None, spec: str) -> str:
    return "—" if x is None or not np.isfinite(x) else format(x, spec)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--variants", nargs="+", default=["none", "stress", "peak", "overstress"],
                    choices=["none", "stress", "peak", "overstress"])
    ap.add_argument("--tests", nargs="+", default=["ramps", "cycles", "relax"],
                    choices=["ramps", "cycles", "relax"])
    ap.add_argument("--wide", action="store_true",
                    help="the ramps' wide priors of G and tau_max for every test")
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args(argv)
    have = {"ramps": RAMPS.is_file(), "cycles": CYCLES.is_file(), "relax": RELAX.is_file()}
    tests = [t for t in args.tests if have[t]]
    for t in args.tests:
        if not have[t]:
            print(f"{t}: the real export is absent ({RAMPS if t == 'ramps' else EXPORTS}); skipped")
    if not tests:
        return 0
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        jobs = []
        if "ramps" in tests:
            for k, path in enumerate(ramp_files(Path(tmp)), 1):
                jobs += [(tmp, "ramps", str(path), k, w, v, args.wide) for w in (SMALL, None)
                         for v in args.variants]
        if "cycles" in tests:
            jobs += [(tmp, "cycles", str(CYCLES), k, None, v, args.wide) for k in range(1, 7)
                     for v in args.variants]
        if "relax" in tests:
            jobs += [(tmp, "relax", str(RELAX), k, None, v, args.wide) for k in range(1, 4)
                     for v in args.variants]
        with ProcessPoolExecutor(args.jobs) as pool:
            results = list(pool.map(one_fit, jobs))
    print(f"{len(results)} fits in {time.perf_counter() - t0:.0f} s ({args.jobs} jobs); white least "
          f"squares; E(t) is the σ -> 0 limit (the reference spectrum) at the test's temperature")
    head = (f"{'test':<9}{'spec':>4} {'window':>7} {'driving':>10} {'rms':>7} {'rms<=4%':>8} "
            f"{'sigma_s ± sd':>15} {'E':>7} {'G':>7} {'tau_max':>9} "
            + "".join(f"{'E(' + format(t, 'g') + ' s)':>10}" for t in TIMES) + f"{'unload':>8}")
    print(head)
    for r in results:
        w = "whole" if r["window"] is None else f"{100 * r['window']:g} %"
        lead = f"{r['kind']:<9}{r['specimen']:>4} {w:>7} {r['variant']:>10} "
        if "error" in r:
            print(lead + "failed: " + r["error"])
            continue
        ss = ("—" if r["sigma_s"] is None else
              f"{r['sigma_s']:.3g} ± {_fmt(r['sigma_s_sd'], '.2g')}")
        print(lead + f"{r['rms']:>7.3f} {_fmt(r['rms_small'], '.3f'):>8} {ss:>15} {r['E']:>7.0f} "
              f"{r['G']:>7.2f} {r['tau_max']:>9.3g} "
              + "".join(f"{m:>10.0f}" for m in r["modulus"])
              + f"{_fmt(r.get('unload'), '.2f'):>8}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
