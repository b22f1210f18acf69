"""Simulation-based calibration (Talts et al. 2018) of the whole pipeline, run on the batch runner.

1. Draw N parameter sets from a prior narrowed to the physical range of the shipped example
   runs/hdpe-a-5e-3 (E uniform 2400-3300 MPa, G uniform 1.5-3.5 MPa, tau_max log-uniform 2-15 s);
   the same prior is the one the sampler uses.
2. Write one template config and a manifest (one row per draw: truth.params.*, truth.seed,
   sampler.seed, data.file); simulate each test (bayes_dnlr.workflows.simulate: a 5e-3 1/s ramp to strain 1.9,
   stress noise 0.3 MPa; exact strain).
3. Run fit + sample for every test with ``python -m bayes_dnlr batch`` machinery (joblib locally, or a
   Dask cluster with --scheduler); resumable: run the same command again after a stop.
4. For each test, the rank of the truth among the posterior draws thinned by ceil(τ) steps; PIT
   u = (rank + U)/(L + 1); the ECDF of the N PIT values against its simultaneous 95 % band
   (Säilynoja et al. 2022), per parameter. Calibrated: every ECDF inside its band.

``--alpha``: the spectrum's exponent is sampled too (prior Normal(0.5, 0.05) cut to 0.35-0.65,
the truths drawn from it); its posterior is far from the linearization, so every test's chain
runs ``sample``'s complement move (DEMove 0.3 + a Student t fitted to the other walkers 0.7).

The likelihood is a config passthrough: ``--likelihood white`` (``noise.discrepancy: none``) or
``--likelihood discrepancy`` (an exp discrepancy whose amplitude (half-normal, scale 1 MPa) and
length (log-uniform 5-100 s) are drawn per test from the same prior and added to the data as an
Ornstein-Uhlenbeck error; their ranks are checked too).

``--shift``: the shift factor's parameters are sampled too (docs/theory.md, "The shift factor"):
each simulation is one run of three ramps (``tests:``) at 0, 10 and 20 °C into the nonlinear
range (to strain 0.1, ``--points`` per test, 300 by default), made and fitted with an Arrhenius
a_T about 20 °C and an Eyring a_σ driven by the true stress; E, G, tau_max, Ea (uniform 100-200
kJ/mol) and sigma_s (log-uniform 2-10 MPa) are shared by the three tests. The reference is the
warmest temperature: a test above it could relax so far within the prior (tau_max 2 s, sigma_s
2 MPa, Ea 200 kJ/mol at 30 °C: a peak stress of 1 MPa) that the data check refuses it (no tensile
load: a peak within 10 noise sd of zero); at 20 °C the lowest peak over the prior's corners is
4.7 MPa. A manifest cannot
address a test of ``tests:``, so every simulation is a config of its own (``<out>/sims/``).

    .venv/bin/python benchmarks/sbc.py --sims 200 --jobs 2 --out /work/wt/h5-batch-out/sbc-white
    .venv/bin/python benchmarks/sbc.py --likelihood discrepancy --sims 200 --out .../sbc-discrepancy
    .venv/bin/python benchmarks/sbc.py --alpha --sims 200 --out .../sbc-alpha
    .venv/bin/python benchmarks/sbc.py --shift --sims 200 --out .../sbc-shift
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np
import yaml

PRIOR = {"E": {"prior": "uniform", "low": 2400.0, "high": 3300.0},
         "G": {"prior": "uniform", "low": 1.5, "high": 3.5},
         "tau_max": {"prior": "log-uniform", "low": 2.0, "high": 15.0}}
ALPHA_PRIOR = {"prior": "normal", "mean": 0.5, "sd": 0.05, "low": 0.35, "high": 0.65}
DISC_PRIOR = {"amplitude": {"prior": "half-normal", "scale": 1.0},
              "length": {"prior": "log-uniform", "low": 5.0, "high": 100.0}}
SHIFT_PRIOR = {"Ea": {"prior": "uniform", "low": 100.0, "high": 200.0},
               "sigma_s": {"prior": "log-uniform", "low": 2.0, "high": 10.0}}
SHIFT = {"temperature": "arrhenius", "reference_temperature": 20.0, "stress": "eyring"}
SHIFT_TEMPERATURES = (0.0, 10.0, 20.0)      # °C: a_T 20-400, 4-18 and 1 over the prior of Ea
SHIFT_STRAIN_MAX = 0.1                       # into the Eyring flow at sigma_s 2-10 MPa
SHIFT_POINTS = 300                           # per test
SIGMA0 = 0.3


def prior(args: argparse.Namespace) -> dict[str, dict]:
    """The sampled model parameters' priors (and the truths' distribution)."""
    return PRIOR | ({"alpha": ALPHA_PRIOR} if args.alpha else {}) | (SHIFT_PRIOR if args.shift else {})


def points(args: argparse.Namespace) -> int:
    """Samples per test: --points, else 1000 (300 per test with --shift)."""
    return args.points if args.points is not None else (SHIFT_POINTS if args.shift else 1000)


def draw(spec: dict, rng: np.random.Generator) -> float:
    if spec["prior"] == "normal":           # cut to [low, high], as the config's prior
        while not spec["low"] <= (x := float(rng.normal(spec["mean"], spec["sd"]))) <= spec["high"]:
            pass
        return x
    if spec["prior"] == "uniform":
        return float(rng.uniform(spec["low"], spec["high"]))
    if spec["prior"] == "log-uniform":
        return float(math.exp(rng.uniform(math.log(spec["low"]), math.log(spec["high"]))))
    if spec["prior"] == "half-normal":
        return float(abs(rng.normal(0.0, spec["scale"])))
    raise ValueError(spec)


def template(args: argparse.Namespace) -> dict:
    white = args.likelihood == "white"
    disc = "none" if white else {"kernel": "exp", "axis": "time", **DISC_PRIOR}
    return {
        "name": "sbc",
        "data": {"file": "data/placeholder.csv",
                 "columns": {"time": "t_s", "eps11": "eps11", "stress": "stress_MPa"},
                 "observable": "stress", "strain_input": "measured"},
        "model": {"modes": 50, "decades": 6},
        "parameters": prior(args),
        "noise": {"sigma0": SIGMA0, "discrepancy": disc},
        "sampler": {"walkers": 32, "max_steps": 20000, "target_ess": args.target_ess, "seed": 1,
                    "checkpoint_every": 200, "moves": args.moves},
        "fit": {"multistart": 4},
        "truth": {"params": {"E": 2854.0, "G": 2.32, "tau_max": 5.79}, "strain_rate": 5.0e-3,
                  "strain_max": 1.9, "n_points": points(args),
                  "noise": {"strain_sd": 0.0, "stress_sd": SIGMA0}, "seed": 0},
    }


def shift_config(args: argparse.Namespace, name: str, truth: dict[str, float], seed: int) -> dict:
    """One --shift simulation: its three ramps at SHIFT_TEMPERATURES in one run, from ``truth``."""
    base = template(args)
    tests = []
    for k, temp in enumerate(SHIFT_TEMPERATURES):
        test = f"T{temp:g}"
        tests.append({
            "name": test, "data": base["data"] | {"file": f"{test}.csv", "temperature": temp},
            "noise": base["noise"],
            "truth": {"params": dict(truth), "shift": dict(SHIFT), "temperature": temp,
                      "strain_rate": 5.0e-3, "strain_max": SHIFT_STRAIN_MAX, "n_points": points(args),
                      "noise": {"strain_sd": 0.0, "stress_sd": SIGMA0}, "seed": seed + k}})
    # G stays free where the windows hardly see it (the fit would hold it at 0, off the prior that
    # made the truth): its prior is the truths' distribution
    return {"name": name, "tests": tests, "model": base["model"] | {"shift": dict(SHIFT)},
            "parameters": base["parameters"], "sampler": base["sampler"],
            "fit": base["fit"] | {"hold_unidentified": False}}


def write_inputs(args: argparse.Namespace, out: Path
                 ) -> tuple[Path, Path | list[Path], dict[str, dict[str, float]]]:
    """template.yaml and manifest.csv in ``out`` (kept when already there: a resumed run); with
    --shift, template.yaml and one config per simulation (their paths instead of the manifest)."""
    out.mkdir(parents=True, exist_ok=True)
    tpl, man = out / "template.yaml", out / "manifest.csv"
    rng = np.random.default_rng(args.seed)
    rows, truths = [], {}
    for i in range(args.sims):
        name = f"sim{i:04d}"
        truth = {k: draw(v, rng) for k, v in prior(args).items()}
        row = {"name": name, "data.file": f"data/{name}.csv", "sampler.seed": i + 1,
               "truth.seed": 100_000 + i, **{f"truth.params.{k}": f"{v:.10g}" for k, v in truth.items()}}
        if args.likelihood == "discrepancy":
            amp, length = draw(DISC_PRIOR["amplitude"], rng), draw(DISC_PRIOR["length"], rng)
            row.update({"truth.noise.correlated.kernel": "exp",
                        "truth.noise.correlated.amplitude": f"{amp:.10g}",
                        "truth.noise.correlated.length": f"{length:.10g}"})
            truth.update({"disc_amplitude": amp, "disc_length": length})
        rows.append(row)
        truths[name] = {k: float(f"{v:.10g}") for k, v in truth.items()}
    text = yaml.safe_dump(template(args), sort_keys=False)
    if tpl.exists() and tpl.read_text() != text:
        sys.exit(f"{tpl} exists with other settings: use another --out")
    tpl.write_text(text)
    if args.shift:        # one config per simulation (a manifest cannot address tests: entries)
        configs = []
        for row in rows:
            folder = out / "sims" / row["name"]
            folder.mkdir(parents=True, exist_ok=True)
            raw = shift_config(args, row["name"], truths[row["name"]], int(row["truth.seed"]))
            raw["sampler"] = raw["sampler"] | {"seed": row["sampler.seed"]}
            (folder / "config.yaml").write_text(yaml.safe_dump(raw, sort_keys=False))
            configs.append(folder / "config.yaml")
        return tpl, configs, truths
    with open(man, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    return tpl, man, truths


def ranks(rows: list[dict], truths: dict[str, dict[str, float]], names: list[str]) -> dict:
    """Per parameter: ranks of the truth among the posterior draws thinned by ceil(max τ)."""
    import xarray as xr

    from bayes_dnlr.inference.analyses.sbc import rank_of, thin_draws

    out: dict[str, dict[str, list]] = {p: {"rank": [], "L": [], "sim": []} for p in names}
    for r in rows:
        if r.get("status") != "ok":
            continue
        run = Path(r["run_dir"])
        summary = json.loads((run / "summary.json").read_text())
        tau = max(summary["autocorr_time"][p] for p in names)
        with xr.open_datatree(run / "posterior.nc", engine="h5netcdf") as dt:
            post = dt["posterior"]
            for p in names:
                draws = post[p].transpose("draw", ...).values
                rk, L = rank_of(truths[r["name"]][p], thin_draws(draws, tau))
                out[p]["rank"].append(rk)
                out[p]["L"].append(L)
                out[p]["sim"].append(r["name"])
    return out


def plot(pits: dict[str, np.ndarray], band: tuple, path: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from bayes_dnlr.inference.analyses.sbc import ecdf

    z, lo, hi, _ = band
    fig, axes = plt.subplots(1, len(pits), figsize=(4.2 * len(pits), 3.6), sharey=True, squeeze=False)
    for ax, (p, u) in zip(axes[0], pits.items(), strict=True):
        ax.fill_between(z, lo - z, hi - z, step="mid", color="0.85", label="95 % simultaneous band")
        ax.step(z, ecdf(u, z) - z, where="mid", color="#1f5fa8", lw=1.4, label="rank ECDF − uniform")
        ax.axhline(0, color="0.4", lw=0.6)
        ax.set_title(p)
        ax.set_xlabel("fractional rank u")
    axes[0, 0].set_ylabel("ECDF(u) − u")
    axes[0, 0].legend(fontsize=8, loc="lower left")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sims", type=int, default=200)
    ap.add_argument("--jobs", type=int, default=-1)
    ap.add_argument("--scheduler", default=None, help="Dask scheduler address (as batch --scheduler)")
    ap.add_argument("--points", type=int, default=None, help="per test: 1000 (300 with --shift)")
    ap.add_argument("--target-ess", type=float, default=400.0)
    ap.add_argument("--likelihood", choices=("white", "discrepancy"), default="white")
    ap.add_argument("--seed", type=int, default=2018)
    ap.add_argument("--moves", default="de", help="sampler.moves (de-plain: DEMove alone)")
    ap.add_argument("--alpha", action="store_true", help="sample the spectrum's exponent too")
    ap.add_argument("--shift", action="store_true",
                    help="three temperatures in one run, Arrhenius and Eyring: Ea and sigma_s sampled")
    ap.add_argument("--out", type=Path, required=True, help="folder for the runs, table and plot")
    args = ap.parse_args()

    from bayes_dnlr.inference.analyses.sbc import inside_band, pit_from_ranks, simultaneous_band
    from bayes_dnlr.workflows.batch.manifest import jobs_from_configs, jobs_from_manifest
    from bayes_dnlr.workflows.batch.page import run_campaign
    from bayes_dnlr.workflows.simulate import simulate_tests

    out = args.out.resolve()
    t0 = time.perf_counter()
    tpl, man, truths = write_inputs(args, out)
    jobs = jobs_from_configs(man) if args.shift else jobs_from_manifest(tpl, man, out)
    for job in jobs:
        if job.error:
            sys.exit(job.error)
        simulate_tests(job.config())
    t_sim = time.perf_counter() - t0
    # the simulations' E come from the prior, not a population of specimens: no population step
    inputs, manifest = ([str(p) for p in man], None) if args.shift else ([str(tpl)], man)
    result = run_campaign(inputs, manifest=manifest, out=out, n_jobs=args.jobs,
                          scheduler=args.scheduler, report=False, population=False)
    wall = time.perf_counter() - t0
    print(result.summary())
    names = list(prior(args)) + (["disc_amplitude", "disc_length"] if args.likelihood == "discrepancy"
                                 else [])
    rk = ranks(result.rows, truths, names)
    n = len(rk["E"]["rank"])
    rng = np.random.default_rng(args.seed + 1)
    pits = {p: pit_from_ranks(np.array(v["rank"]), np.array(v["L"]), rng) for p, v in rk.items()}
    band = simultaneous_band(n, 0.95, rng=np.random.default_rng(args.seed + 2))
    ok = result.rows and all(r.get("status") == "ok" for r in result.rows)
    conv = sum(bool(r.get("converged")) for r in result.rows)
    sampling = [r.get("sampling_time_s") or 0.0 for r in result.rows if r.get("status") == "ok"]
    elapsed = [r.get("elapsed_s") or 0.0 for r in result.rows
               if r.get("status") == "ok" and not r.get("reused")]
    cores = os.cpu_count()
    print(f"\nSBC, {args.likelihood} likelihood{', shifted' if args.shift else ''}: {n} simulations "
          f"({points(args)} points{' per test, 3 tests' if args.shift else ''}, target ESS "
          f"{args.target_ess:g}); converged {conv}/{len(result.rows)}")
    print(f"wall time {wall:.0f} s this invocation (simulating the data {t_sim:.0f} s) on "
          f"{result.backend}; machine cores {cores}")
    if elapsed:
        print(f"per test (computed this invocation): median {np.median(elapsed):.1f} s in its worker, "
              f"median sampling {np.median(sampling):.1f} s")
    print(f"draws per test after thinning by ceil(tau): median {int(np.median(rk['E']['L']))} "
          f"(range {min(rk['E']['L'])}-{max(rk['E']['L'])})")
    print(f"{'parameter':<15} {'max|ECDF-u|':>11}  inside the 95 % simultaneous band")
    verdict = {}
    z, lo, hi, _ = band
    for p, u in pits.items():
        from bayes_dnlr.inference.analyses.sbc import ecdf

        inside = inside_band(u, z, lo, hi)
        verdict[p] = inside
        print(f"{p:<15} {np.abs(ecdf(u, z) - z).max():>11.4f}  {'yes' if inside else 'NO'}")
    tag = f"{args.likelihood}{'_alpha' if args.alpha else ''}{'_shift' if args.shift else ''}"
    png = out / f"sbc_rank_ecdf_{tag}.png"
    plot(pits, band, png, f"SBC, {args.likelihood} likelihood{', shifted model' if args.shift else ''}: "
                          f"{n} simulations, rank ECDF − uniform with 95 % simultaneous bands")
    (out / f"sbc_{tag}.json").write_text(json.dumps(
        {"n": n, "ranks": rk, "inside_band": verdict, "wall_time_s": wall, "cores": cores,
         "backend": result.backend, "settings": vars(args) | {"out": str(out)}}, indent=1))
    print(f"plot: {png}")
    sys.exit(0 if ok and all(verdict.values()) else 1)


if __name__ == "__main__":
    main()
