"""Nothing lost on clean data: the shipped examples (white noise) sampled with the white likelihood
and with the default model-discrepancy likelihood, side by side.

    .venv/bin/python benchmarks/clean_data.py [--examples hdpe-a-5e-3 ...]

Prints, per example and parameter: the truth, both posteriors (mean ± sd), the ratio of the sds
(the issue's bound: within 15 %), |mean - truth| in sd, the discrepancy amplitude's posterior, steps
and sampling-loop time of each run. Runs in a temporary folder (nothing written into runs/).
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
from pathlib import Path

import yaml

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = ["hdpe-a-2.5e-3", "hdpe-a-5e-3", "hdpe-a-1e-2", "hdpe-b-relax-5e-3"]


def run(example: str, tmp: Path, discrepancy: object):
    from bayes_dnlr.config import load_config
    from bayes_dnlr.runs.sample import sample

    tag = "white" if discrepancy == "none" else "disc"
    dst = tmp / f"{example}-{tag}"
    dst.mkdir()
    src = REPO / "runs" / example
    raw = yaml.safe_load((src / "config.yaml").read_text())
    for f in src.glob("*.csv"):
        shutil.copy(f, dst / f.name)
    raw["name"] = dst.name
    if discrepancy is not None:
        raw.setdefault("noise", {})["discrepancy"] = discrepancy
    (dst / "config.yaml").write_text(yaml.safe_dump(raw, sort_keys=False))
    cfg = load_config(dst / "config.yaml")
    return cfg, sample(cfg, progress=False).summary


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--examples", nargs="+", default=EXAMPLES)
    args = p.parse_args(argv)
    worst = 0.0
    with tempfile.TemporaryDirectory() as tmp:
        for ex in args.examples:
            cfg, white = run(ex, Path(tmp), "none")
            _, disc = run(ex, Path(tmp), None)
            truth = cfg.truth.params
            print(f"\n{ex}: white {white['steps']} steps {white['wall_time_s']:.2f} s; "
                  f"discrepancy ({disc['noise'].get('kernel')}) {disc['steps']} steps "
                  f"{disc['wall_time_s']:.2f} s")
            print(f"  {'parameter':<10}{'truth':>10}{'white mean ± sd':>24}{'discrepancy mean ± sd':>26}"
                  f"{'sd ratio':>10}{'z white':>9}{'z disc':>8}")
            for k in white["parameters"]:
                w, d = white["posterior"][k], disc["posterior"][k]
                ratio = d["sd"] / w["sd"]
                worst = max(worst, abs(ratio - 1.0))
                print(f"  {k:<10}{truth[k]:>10.6g}{w['mean']:>14.6g} ± {w['sd']:<8.3g}"
                      f"{d['mean']:>16.6g} ± {d['sd']:<8.3g}{ratio:>10.3f}"
                      f"{(w['mean'] - truth[k]) / w['sd']:>+9.2f}{(d['mean'] - truth[k]) / d['sd']:>+8.2f}")
            amp = disc["posterior"].get("disc_amplitude")
            if amp:
                print(f"  disc_amplitude {amp['mean']:.3g} ± {amp['sd']:.2g} MPa "
                      f"(90 % HDI {amp['hdi_90'][0]:.2g}-{amp['hdi_90'][1]:.2g}); "
                      f"verdict: {disc['noise']['verdict']}")
    print(f"\nlargest |sd ratio - 1| over the model parameters: {worst:.3f} (bound 0.15)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
