"""Fit the three real ETFE specimens of ../shared/data/real (not part of the project; see its README).

    .venv/bin/python benchmarks/real_etfe.py [--method lm|gauss-newton] [--strain-input smoothed|measured]

Each specimen (time, Hencky axial strain SOI, true stress) goes to a temporary CSV + config (never
into the project), through the ordinary pipeline: load_test, fit (E, G, tau_max on the whole curve,
sigma0 from the residuals). Prints the estimates, rms residual and residual diagnostics. Exits cleanly
with a message when ../shared/data/real is absent (a user's clone has no ../shared).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np
import yaml

REPO = Path(__file__).resolve().parents[1]
REAL = REPO.parent / "shared" / "data" / "real"
FILE = "ETFE_MD_CSR_0p1pct_per_s_T40C_3specimens.csv"
# per specimen k the columns are 15 k + offset (README): time, Hencky axial strain (SOI), true stress
TIME, HENCKY_SOI, TRUE_STRESS_SOI = 0, 7, 9


def specimens(path: Path) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """(time, strain, stress) of each specimen, padding rows dropped."""
    a = np.genfromtxt(path, delimiter=",")
    out = []
    for k in range(a.shape[1] // 15):
        t, e, s = (a[:, 15 * k + c] for c in (TIME, HENCKY_SOI, TRUE_STRESS_SOI))
        keep = np.isfinite(t) & np.isfinite(e) & np.isfinite(s)
        out.append((t[keep], e[keep], s[keep]))
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--method", default="lm", choices=["lm", "gauss-newton"])
    p.add_argument("--strain-input", default="smoothed", choices=["smoothed", "measured"])
    p.add_argument("--multistart", type=int, default=8)
    p.add_argument("--tables", action="store_true", help="print the full fit table of each specimen")
    args = p.parse_args(argv)
    path = REAL / FILE
    if not path.is_file():
        print(f"{path} not found: the real data live outside the project (../shared/data/real); "
              "nothing to do")
        return 0

    from bayes_dnlr.config import load_config
    from bayes_dnlr.pipeline.fit import fit

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for k, (t, e, s) in enumerate(specimens(path)):
            name = f"etfe-{k}"
            run = Path(tmp) / name
            run.mkdir()
            np.savetxt(run / "data.csv", np.column_stack([t, e, s]), delimiter=",",
                       header="t_s,eps11,sigma_MPa", comments="", fmt="%.10g")
            raw = {"name": name,
                   "data": {"file": "data.csv", "columns": {"time": "t_s", "eps11": "eps11",
                                                            "stress": "sigma_MPa"},
                            "observable": "stress", "strain_input": args.strain_input},
                   "noise": {"sigma0": "residuals"},
                   "fit": {"method": args.method, "multistart": args.multistart}}
            (run / "config.yaml").write_text(yaml.safe_dump(raw))
            cfg = load_config(run / "config.yaml")
            r = fit(cfg)
            if args.tables:
                print(r.table(), "\n")
            d = r.diagnostics
            rows.append((name, t.size, float(e.max()), r.strain_rate, r.estimate, r.sd, d, r.multistart,
                         r.iterations, r.converged, r.wall_time_s))

    print(f"ETFE, machine direction, 40 °C (README: {FILE}); method {args.method}, "
          f"strain input {args.strain_input}, sigma0 from the residuals")
    print(f"{'specimen':<9}{'n':>6}{'eps_max':>8}{'rate 1/s':>10}{'E MPa':>10}{'sd':>7}{'G MPa':>8}{'sd':>7}"
          f"{'tau_max s':>10}{'sd':>7}{'rms MPa':>8}{'r1':>7}{'DW':>6}{'runs/exp':>11}{'white':>6}"
          f"{'ms':>6}{'it':>4}{'s':>6}")
    for name, n, emax, rate, est, sd, d, ms, it, conv, wall in rows:
        runs = d["runs_test"]
        print(f"{name:<9}{n:>6}{emax:>8.3f}{rate:>10.2e}{est['E']:>10.1f}{sd['E']:>7.1f}{est['G']:>8.3f}"
              f"{sd['G']:>7.3f}{est['tau_max']:>10.3f}{sd['tau_max']:>7.3f}{d['rms']:>8.3f}"
              f"{d['lag1_autocorrelation']:>7.3f}{d['durbin_watson']:>6.2f}"
              f"{runs['n_runs']:>5}/{runs['expected']:<5.0f}{'yes' if d['white'] else 'no':>6}"
              f"{ms['converged']:>3}/{ms['starts']:<2}{it:>4}{wall:>6.2f}")
        if not conv:
            print(f"  {name}: NOT converged")
    print("\nverdicts:")
    for name, *_, d, _ms, _it, _c, _w in rows:
        print(f"  {name}: {d['verdict']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
