"""What E(t) adds to ``sample``: the time of its parts against the whole command, on the shipped
example and, when present, a real curve of ../shared/data/real.

The parts: E(t) of every kept draw with its checks (runs/modulus_block.py ``posterior_block``), the
start check's chords of the model curves (runs/bands.py, inside the predictive band the checks
compute anyway) and the E(t) of ``fit`` from its Laplace draws, band and checks included
(runs/modulus_block.py ``fit_rows``). Each is timed on the run's own outputs after a fresh
``sample`` (``--restart``), best of 5.

    .venv/bin/python benchmarks/modulus_cost.py
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

REPO = Path(__file__).resolve().parents[1]
REAL = Path(os.environ.get("BAYES_DNLR_REAL_DATA", REPO.parent / "shared" / "data" / "real"))
ETFE = "ETFE_MD_CSR_0p1pct_per_s_T40C_3specimens.csv"


def best(f, repeat: int = 5) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return min(times)


def measure(config: Path) -> dict[str, float]:
    from bayes_dnlr.config import load_config
    from bayes_dnlr.runs import bands as band_module
    from bayes_dnlr.runs.chain_outputs import chain_layout
    from bayes_dnlr.runs.chains import read_run
    from bayes_dnlr.runs.fit import load_fit
    from bayes_dnlr.runs.layout import CHAINS_FILE
    from bayes_dnlr.runs.modulus_block import fit_rows, posterior_block
    from bayes_dnlr.runs.records import held_config
    from bayes_dnlr.runs.sample import sample
    from bayes_dnlr.runs.testset import load_tests

    cfg = load_config(config)
    t0 = time.perf_counter()
    post = sample(cfg, restart=True, progress=False)
    total = time.perf_counter() - t0
    fit = load_fit(cfg.run_dir)
    used = held_config(cfg, fit)
    tests = load_tests(cfg)
    run = read_run(cfg.run_dir / CHAINS_FILE)
    draws = run.chain[post.summary["burn_in"]:]
    layout = chain_layout(run, cfg, tests.plain)
    names = run.names
    summary = post.summary
    sigma0 = {t: float(summary["sigma0"]) for t in layout.tests}
    noise = layout.expand(summary.get("noise"))
    bands = band_module.predictive_bands(used, tests, layout, draws, names, noise, sigma0)
    checks = dict(summary["checks"])
    checks["noise_model"] = layout.expand(checks.get("noise_model"))
    block = best(lambda: posterior_block(used, tests, layout, draws, names, bands, checks, None,
                                       True, fit))
    original = band_module.start_check
    band_module.start_check = lambda *a, **k: None
    def bands_now():
        return band_module.predictive_bands(used, tests, layout, draws, names, noise, sigma0)

    without = best(bands_now, 3)
    band_module.start_check = original
    with_start = best(bands_now, 3)
    data = next(iter(tests.tests.values()))
    lin = best(lambda: fit_rows(cfg, data, fit))
    return {"sample_s": total, "modulus_block_s": block, "start_check_s": max(with_start - without, 0.0),
            "fit_block_s": lin}


def main() -> int:
    cases = [REPO / "runs" / "hdpe-a-5e-3" / "config.yaml"]
    with tempfile.TemporaryDirectory() as tmp:
        if (REAL / ETFE).is_file():
            from real_etfe import specimens

            t, e, stress = specimens(REAL / ETFE)[0]
            run = Path(tmp) / "etfe"
            run.mkdir()
            np.savetxt(run / "etfe.csv", np.column_stack([t, e, stress]), delimiter=",",
                       header="t_s,eps11,sigma_MPa", comments="", fmt="%.10g")
            raw = {"name": "etfe", "data": {"file": "etfe.csv", "observable": "stress",
                                            "columns": {"time": "t_s", "eps11": "eps11",
                                                        "stress": "sigma_MPa"}},
                   "noise": {"sigma0": "residuals"}}
            (run / "config.yaml").write_text(yaml.safe_dump(raw))
            cases.append(run / "config.yaml")
        for c in cases:
            m = measure(c)
            added = m["modulus_block_s"] + m["start_check_s"] + m["fit_block_s"]
            print(f"{c.parent.name}: sample {m['sample_s']:.2f} s; E(t) of the draws with its checks "
                  f"{1e3 * m['modulus_block_s']:.1f} ms, the start check {1e3 * m['start_check_s']:.1f} ms, "
                  f"the E(t) of fit {1e3 * m['fit_block_s']:.1f} ms: "
                  f"{100 * added / m['sample_s']:.1f} % of sample")
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(REPO))
    sys.path.insert(0, str(REPO / "benchmarks"))
    sys.exit(main())
