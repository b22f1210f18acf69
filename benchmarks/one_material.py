"""One material, tests of two kinds: do their E(t) agree, and does the consistency check fire when
one kind comes from another material?

Synthetic tests made by ``simulate`` from a richer model than the fitted one (``truth.model_form``,
mild by default) for one material: loading-unloading cycles (four, to strain 0.02 at 1e-3 1/s) and
a ramp then a hold (to strain 0.01, then 600 s), both sampled at 5 Hz with 0.02 MPa of stress noise,
as a real film's tests are. Each test is sampled alone (the default config), and both in one joint
run sharing E and the spectrum; then again with the hold test made from another material (E × 1.4).
It prints E(t) of each test at the time both resolve, their difference in combined sd, the joint
run's ``consistency``, and each sample's steps and time against the reference job.

    .venv/bin/python benchmarks/one_material.py [--form spectrum-power] [--strength mild] [--seeds 3]
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

REPO = Path(__file__).resolve().parents[1]
MATERIAL = {"E": 2000.0, "G": 5.0, "tau_max": 60.0}
HOLD_PARAMS = {"sigma_inf": 6.0, "tau_max_R": 120.0}
NOISE = {"strain_sd": 0.0, "stress_sd": 0.02}
COLUMNS = {"time": "t_s", "strain": "eps", "stress": "s"}


def reference_job() -> float:
    """The fixed reference job's time (../shared/tools/refjob.py), in s, or NaN without it."""
    tool = REPO.parent / "shared" / "tools" / "refjob.py"
    if not tool.is_file():
        return math.nan
    out = subprocess.run([sys.executable, str(tool)], capture_output=True, text=True, check=False)
    for word in out.stdout.replace("=", " ").split():
        try:
            return float(word.rstrip("s"))
        except ValueError:
            continue
    return math.nan


def tests(form: str | None, strength: str, seed: int, other: float = 1.0) -> list[dict]:
    """The cycles and the ramp-then-hold of one material (the hold's E × ``other``)."""
    model_form = {"model_form": {"kind": form, "strength": strength}} if form else {}
    cycles = {"name": "cycles", "data": {"file": "cycles.csv", "columns": COLUMNS, "observable": "stress"},
              "truth": {"params": MATERIAL, "strain_rate": 1e-3, "strain_max": 0.02,
                        "cycles": {"count": 4}, "sample_rate": 5, "noise": NOISE, "seed": 10 + seed,
                        **model_form}}
    hold_params = {**MATERIAL, "E": MATERIAL["E"] * other, **HOLD_PARAMS}
    hold = {"name": "hold", "data": {"file": "hold.csv", "columns": COLUMNS, "observable": "stress",
                                     "relaxation_start": 10.0},
            "truth": {"params": hold_params, "strain_rate": 1e-3, "strain_max": 0.01, "hold": 600.0,
                      "sample_rate": 5, "noise": NOISE, "seed": 20 + seed, **model_form}}
    return [cycles, hold]


def run(folder: Path, name: str, raw: dict) -> tuple[dict, float]:
    from bayes_dnlr.config import load_config
    from bayes_dnlr.runs.sample import sample
    from bayes_dnlr.workflows.simulate import simulate_tests

    run_dir = folder / name
    run_dir.mkdir(parents=True, exist_ok=True)
    path = run_dir / "config.yaml"
    path.write_text(yaml.safe_dump({"name": name, **raw}, sort_keys=False))
    cfg = load_config(path)
    simulate_tests(cfg)
    t0 = time.perf_counter()
    s = sample(cfg, progress=False).summary
    return s, time.perf_counter() - t0


def one_case(folder: Path, form: str | None, strength: str, seed: int, other: float) -> dict:
    specs = tests(form, strength, seed, other)
    out: dict = {"seed": seed, "other": other, "alone": {}}
    for spec in specs:
        raw = {"data": spec["data"], "truth": spec["truth"], "sampler": {"seed": seed + 1}}
        s, wall = run(folder, f"{spec['name']}-{seed}-{other}", raw)
        row = s["modulus_at"][0]
        out["alone"][spec["name"]] = {"t": row["t"], "mean": row["mean"], "sd": row["sd"],
                                      "trust": row["trust"], "steps": s["steps"], "wall_s": wall,
                                      "reasons": row["trust_reasons"]}
    joint = {"tests": [{k: v for k, v in spec.items()} for spec in specs],
             "sampler": {"seed": seed + 1}}
    s, wall = run(folder, f"joint-{seed}-{other}", joint)
    out["joint"] = {"consistency": s.get("consistency"), "steps": s["steps"], "wall_s": wall,
                    "E": s["posterior"]["E"]}
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--form", default="spectrum-power",
                    help="truth.model_form kind ('none': the fitted model)")
    ap.add_argument("--strength", default="mild")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    form = None if args.form == "none" else args.form
    unit = reference_job()
    print(f"model form {args.form} ({args.strength}); reference job {unit:.3f} s")
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(args.seeds):
            for other in (1.0, 1.4):
                r = one_case(Path(tmp), form, args.strength, seed, other)
                results.append(r)
                a, b = r["alone"]["cycles"], r["alone"]["hold"]
                z = (a["mean"] - b["mean"]) / math.hypot(a["sd"], b["sd"]) if a["t"] == b["t"] else math.nan
                c = r["joint"]["consistency"] or {}
                print(f"seed {seed} hold E x{other}: E({a['t']:g} s) cycles {a['mean']:.0f} ± {a['sd']:.0f} "
                      f"({'trusted' if a['trust'] else 'NOT trusted'}), hold {b['mean']:.0f} ± {b['sd']:.0f} "
                      f"({'trusted' if b['trust'] else 'NOT trusted'}): {z:+.2f} combined sd; joint: "
                      f"{'agree' if c.get('agree') else 'DISAGREE'}")
                for name, x in r["alone"].items():
                    print(f"    {name}: {x['steps']} steps, {x['wall_s']:.1f} s = {x['wall_s'] / unit:.1f} "
                          "reference jobs" + (f"; {'; '.join(x['reasons'])}" if x["reasons"] else ""))
                print(f"    joint: {r['joint']['steps']} steps, {r['joint']['wall_s']:.1f} s = "
                      f"{r['joint']['wall_s'] / unit:.1f} reference jobs; {c.get('words')}")
    if args.out is not None:
        args.out.write_text(json.dumps(results, indent=1, default=float))
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(REPO))
    sys.exit(main())
