"""The user's wall time and the chain's steps with the model discrepancy, each beside the reference
job timed in the same run (``../shared/tools/refjob.py``, when present) and the load average.

(a) steps to ESS 1000 (the stopping rule), discrepancy against white, each with ``sampler.moves``
    ``de-plain`` (DEMove alone) and ``de`` (with the conditional move; the white chain with the
    Laplace move), on the shipped example re-simulated with a correlated error (exp kernel,
    amplitude 0.5 MPa, length 20 s) and on the three real ETFE specimens (../shared/data/real, the
    config of benchmarks/real_etfe.py; skipped when absent); E, G, tau_max mean ± sd beside, and
    the difference of the posterior means between the two moves in Monte Carlo standard errors
    (sd / √ESS bulk of each run);
(b) ``sample`` on the shipped example (the ``make demo`` config) from an empty run folder;
(c) real ETFE specimen 1 from an empty run folder: ``sample`` (fit included) + ``report``.

    .venv/bin/python benchmarks/chain_mixing.py [--parts a b c] [--moves de-plain de]
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
from real_etfe import FILE, REAL, specimens  # noqa: E402
from reference_job import load  # noqa: E402
from reference_job import seconds as refjob  # noqa: E402
from sample_command import SHIPPED, copy_run  # noqa: E402

CORRELATED = {"noise": {"strain_sd": 1.0e-4, "stress_sd": 0.3, "force_sd": 0,
                        "correlated": {"kernel": "exp", "amplitude": 0.5, "length": 20.0}}}

RUN = r"""
import json, sys
from bayes_dnlr.config import load_config
from bayes_dnlr.runs.sample import sample

s = sample(load_config(sys.argv[1]), progress=False).summary
print(json.dumps({"steps": s["steps"], "tau": s["autocorr_time"], "loop_s": s["wall_time_s"],
                  "stop": s["stop_reason"], "kernel": (s.get("noise") or {}).get("kernel"),
                  "post": {k: [s["posterior"][k]["mean"], s["posterior"][k]["sd"],
                               s["posterior"][k]["ess_bulk"]] for k in s["parameters"]}}))
"""


def stamp(label: str) -> float | None:
    r = refjob()
    print(f"[{label}] reference job {r if r is None else f'{r:.2f} s'}; {load()}", flush=True)
    return r


def sample_json(cfg: Path) -> dict:
    out = subprocess.run([sys.executable, "-c", RUN, str(cfg)], capture_output=True, text=True,
                         cwd=ROOT)
    if out.returncode:
        raise RuntimeError(out.stderr.strip().splitlines()[-1])
    return json.loads(out.stdout.strip().splitlines()[-1])


def with_moves(cfg: Path, moves: str) -> Path:
    raw = yaml.safe_load(cfg.read_text())
    raw.setdefault("sampler", {})["moves"] = moves
    cfg.write_text(yaml.safe_dump(raw, sort_keys=False))
    for name in ("chains.h5", "posterior.nc", "summary.json"):
        (cfg.parent / name).unlink(missing_ok=True)
    return cfg


def etfe_run(root: Path, k: int, likelihood: str, name: str | None = None) -> Path:
    run = root / (name or f"etfe{k}-{likelihood}")
    run.mkdir(parents=True)
    raw = {"name": run.name,
           "data": {"file": f"../etfe-{k}.csv", "observable": "stress",
                    "columns": {"time": "t_s", "eps11": "eps11", "stress": "sigma_MPa"}},
           "noise": {"sigma0": "residuals"}, "sampler": {"seed": k + 1}}
    if likelihood == "white":
        raw["noise"]["discrepancy"] = "none"
    (run / "config.yaml").write_text(yaml.safe_dump(raw))
    return run / "config.yaml"


def part_a(tmp: Path, moves: list[str]) -> None:
    cases = []
    for lik in ("disc", "white"):
        noise = {"sigma0": "residuals"} if lik == "disc" else {"discrepancy": "none"}
        d = copy_run(tmp / "a", f"corr-{lik}", truth=CORRELATED, noise=noise)
        subprocess.run([sys.executable, "-m", "bayes_dnlr", "simulate", str(d / "config.yaml"),
                        "--force"], check=True, capture_output=True, cwd=ROOT)
        cases.append(("synthetic, exp error 0.5 MPa / 20 s", lik, d / "config.yaml"))
    if (REAL / FILE).is_file():
        for k, (t, e, s) in enumerate(specimens(REAL / FILE)):
            np.savetxt(tmp / f"etfe-{k}.csv", np.column_stack([t, e, s]), delimiter=",",
                       header="t_s,eps11,sigma_MPa", comments="", fmt="%.10g")
            for lik in ("disc", "white"):
                cases.append((f"ETFE specimen {k}", lik, etfe_run(tmp, k, lik)))
    else:
        print(f"  {REAL / FILE} absent: the ETFE rows are skipped")
    stamp("a, start")
    rows: dict[str, dict] = {}
    for label, lik, cfg in cases:
        for mv in moves:
            r = sample_json(with_moves(cfg, mv))
            rows.setdefault(label, {})[f"{lik} {mv}"] = r
            tau = ", ".join(f"{k} {v:.1f}" for k, v in r["tau"].items())
            post = ", ".join(f"{k} {m:.5g} ± {s:.3g}" for k, (m, s, _) in r["post"].items()
                             if k in ("E", "G", "tau_max"))
            print(f"  {label:<38s} {lik:<5s} {mv:<9s} {r['steps']:5d} steps ({r['stop']}), loop "
                  f"{r['loop_s']:.2f} s; tau {tau}; {post}", flush=True)
    for label, r in rows.items():
        for lik in ("disc", "white"):
            runs = [v for k, v in r.items() if k.startswith(lik)]
            if len(runs) != 2:
                continue
            # the posterior with either move: the difference in Monte Carlo se
            a, b = (v["post"] for v in runs)
            se = {k: (a[k][1] ** 2 / a[k][2] + b[k][1] ** 2 / b[k][2]) ** 0.5 for k in a if k in b}
            diff = ", ".join(f"{k} {(b[k][0] - a[k][0]) / se[k]:+.1f} se (sd ratio "
                             f"{b[k][1] / a[k][1]:.3f})" for k in se)
            print(f"  {label}, {lik}: {' -> '.join(k.split()[1] for k in r if k.startswith(lik))}: "
                  f"mean difference {diff}")
        ratios = ", ".join(f"{mv} {r[f'disc {mv}']['steps'] / r[f'white {mv}']['steps']:.2f} x"
                           for mv in moves)
        print(f"  {label}: steps with the discrepancy / white, each with the same moves: {ratios} "
              "(target <= 1.5)")
    stamp("a, end")


def timed(*args: str) -> float:
    t = time.perf_counter()
    subprocess.run([sys.executable, "-m", "bayes_dnlr", *args], check=True, capture_output=True,
                   cwd=ROOT)
    return time.perf_counter() - t


def part_b(tmp: Path, repeats: int = 3) -> None:
    run = tmp / "b" / "hdpe-a-5e-3"
    shutil.copytree(SHIPPED, run, ignore=shutil.ignore_patterns(
        "chains.h5", "posterior.nc", "summary.json", "fit.json", "*.lock", "report*", "figures"))
    cfg = str(run / "config.yaml")
    timed("sample", cfg, "--quiet")            # numba cache warm
    walls = []
    for _ in range(repeats):
        for name in ("chains.h5", "posterior.nc", "summary.json", "fit.json"):
            (run / name).unlink(missing_ok=True)
        r0 = stamp("b")
        w = timed("sample", cfg, "--quiet")
        walls.append(w)
        print(f"  sample, shipped example, empty run folder: {w:.2f} s"
              + (f" = {w / r0:.2f} reference jobs (target <= 2.8)" if r0 else ""), flush=True)


def part_c(tmp: Path, repeats: int = 2) -> None:
    if not (REAL / FILE).is_file():
        print(f"  {REAL / FILE} absent: (c) skipped")
        return
    t, e, s = specimens(REAL / FILE)[1]
    np.savetxt(tmp / "etfe-1.csv", np.column_stack([t, e, s]), delimiter=",",
               header="t_s,eps11,sigma_MPa", comments="", fmt="%.10g")
    for i in range(repeats + 1):
        cfg = etfe_run(tmp, 1, "disc", name=f"etfe1-c{i}")
        r0 = stamp("c") if i else None
        ws = timed("sample", str(cfg), "--quiet")
        wr = timed("report", str(cfg.parent))
        if i:                                   # the first pass warms numba's cache
            print(f"  ETFE specimen 1, empty run folder: sample {ws:.2f} s + report {wr:.2f} s = "
                  f"{ws + wr:.2f} s" + (f" = {(ws + wr) / r0:.2f} reference jobs (target <= 3)"
                                         if r0 else ""), flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--parts", nargs="+", default=["a", "b", "c"], choices=["a", "b", "c"])
    ap.add_argument("--moves", nargs="+", default=["de-plain", "de"])
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        for part in args.parts:
            print(f"({part})", flush=True)
            {"a": lambda: part_a(Path(tmp), args.moves), "b": lambda: part_b(Path(tmp)),
             "c": lambda: part_c(Path(tmp))}[part]()


if __name__ == "__main__":
    main()
