"""Table 4 as data and as checks: how much an independent modulus does for E's interval under model
error, and how often its check fires.

For each kind of benchmarks/misspecification.py (the same generating models, replicates, varied
parameters and tensile tests, the default config with σ0 its true value), a pulse-echo value and a
DMA sweep are made from the same truth (workflows/truth_forms.py: the generating model's spectrum):

- pulse-echo: E'(5 MHz) of the truth (every mode frozen: E itself) × (1 + 0.014 z), reported with
  sd 1.4 % of its value (the paper's ±40 MPa on 2780 MPa);
- DMA: E'(ω) and E''(ω) at 16 frequencies from 0.1 to 100 Hz, each × (1 + 0.01 z), relative_sd 0.01.

Every replicate is fitted (``fit``: the linearized analyses, GLS under model error as ``sample``
would use it; ``--posterior``: sampled, the posterior's 90 % HDI and checks) with:

- ``alone``: the tensile test, the two references held out (``use: check``): E's coverage and width
  from the test alone, and how often each check fires (its power against a wrong spectrum, its false
  alarms on clean data); ``covered|flagged``: covered, or a check fired;
- ``+pulse-echo``: the pulse-echo value in the data (``use: data``);
- ``+DMA``: the sweep in the data;
- ``+DMA, alpha free`` (``--alpha-free``): the sweep in the data and the spectrum's exponent free
  (``parameters.alpha`` uniform on [0, 1]): what a sweep can tell about the spectrum's shape.

    .venv/bin/python benchmarks/reference_moduli.py --replicates 30 --jobs 2 [--alpha-free]
    .venv/bin/python benchmarks/reference_moduli.py --from results.json     # print saved records
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
import zlib
from pathlib import Path
from typing import Any

import numpy as np
import yaml

HERE = Path(__file__).resolve().parent
PE_FREQUENCY = 5.0e6
PE_RELATIVE_SD = 0.014
DMA_TRUTH = {"frequency_min": 0.1, "frequency_max": 100.0, "points_per_decade": 5, "relative_sd": 0.01}
DMA_RELATIVE_SD = 0.01
Z90 = 1.6448536269514722
SOURCES = ("alone", "+pulse-echo", "+DMA")


def _misspecification():
    sys.path.insert(0, str(HERE))
    import misspecification

    return misspecification


def _e(result: dict[str, Any]) -> tuple[float, float, str]:
    """E and its sd as ``sample`` would use them: the generalized analysis under evident model error,
    else the white one (benchmarks/misspecification.py ``fit_replicate``)."""
    d = result.get("discrepancy")
    if d and d.get("evidence") and d.get("estimate"):
        return float(d["estimate"]["E"]), float(d["sd"]["E"]), "generalized"
    return float(result["estimate"]["E"]), float(result["sd"]["E"]), "white"


def _run(base: dict[str, Any], folder: Path, name: str, refs: list[dict], extra: dict | None,
         posterior: bool) -> dict[str, Any]:
    """The source's fit.json (``fit``) or, with ``posterior``, its summary.json (``sample``), read
    into E, its sd and 90 % interval, and each reference's entry."""
    from bayes_dnlr.config import load_config
    from bayes_dnlr.runs.fit import fit
    from bayes_dnlr.runs.sample import sample
    from bayes_dnlr.workflows.simulate import simulate_test
    from bayes_dnlr.workflows.sweeps import simulate_references

    raw = {**base, "name": name, "reference_moduli": refs, **(extra or {})}
    d = folder / name
    d.mkdir(parents=True, exist_ok=True)
    path = d / "config.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    cfg = load_config(path)
    simulate_test(cfg)
    simulate_references(cfg)
    if posterior:
        s = sample(cfg, progress=False).summary
        e = s["posterior"]["E"]
        return {"E": e["mean"], "sd": e["sd"], "interval": e["hdi_90"], "how": "posterior",
                "alpha": (s["posterior"].get("alpha") or {}).get("mean"),
                "references": s.get("reference_moduli") or [], "steps": s["steps"]}
    r = fit(cfg, write=False).to_dict()
    e, sd, how = _e(r)
    return {"E": e, "sd": sd, "interval": [e - Z90 * sd, e + Z90 * sd], "how": how,
            "alpha": r["estimate"].get("alpha"), "references": r.get("reference_moduli") or []}


def replicate(args: tuple) -> dict[str, Any]:
    """One replicate: its references and the fits of every source."""
    folder, kind, strength, rep, alpha_free, posterior = args
    ms = _misspecification()
    from bayes_dnlr.workflows.truth_forms import complex_modulus

    path = ms.write_config(Path(folder), kind, strength, "default", rep, [], 1000.0)
    base = yaml.safe_load(path.read_text())
    truth = base["truth"]
    form = truth.get("model_form") or {}
    true_pe = float(complex_modulus(PE_FREQUENCY, truth["params"], form.get("kind"),
                                    form.get("strength", "mild"))[0][0])
    rng = np.random.default_rng([rep, zlib.crc32(kind.encode())])
    pe_value = true_pe * (1.0 + PE_RELATIVE_SD * rng.standard_normal())
    pe = {"method": "pulse-echo", "value": float(pe_value), "sd": float(PE_RELATIVE_SD * pe_value),
          "frequency": PE_FREQUENCY}
    dma = {"method": "dma", "file": "dma.csv", "relative_sd": DMA_RELATIVE_SD,
           "truth": {**DMA_TRUTH, "seed": 1000 + rep}}
    work = Path(folder) / f"{kind}-{rep:03d}"
    t0 = time.perf_counter()
    out: dict[str, Any] = {"kind": kind, "strength": strength, "rep": rep,
                           "truth_E": float(truth["params"]["E"]), "pulse_echo": pe["value"], "sources": {}}
    runs = {"alone": ([pe, dma], None), "+pulse-echo": ([{**pe, "use": "data"}], None),
            "+DMA": ([{**dma, "use": "data"}], None)}
    if alpha_free:
        runs["+DMA, alpha free"] = ([{**dma, "use": "data"}],
                                    {"parameters": {"alpha": {"prior": "uniform", "low": 0.0, "high": 1.0}}})
    for source, (refs, extra) in runs.items():
        try:
            folder = source.replace("+", "with-").replace(", ", "-").replace(" ", "-")
            r = _run(base, work, folder, refs, extra, posterior)
        except Exception as err:       # a failed fit is a result too: counted, not covered
            out["sources"][source] = {"error": f"{type(err).__name__}: {err}"}
            continue
        lo, hi = r["interval"]
        rec = {"E": r["E"], "sd": r["sd"], "how": r["how"], "covered": lo <= out["truth_E"] <= hi}
        if r.get("alpha") is not None:
            rec["alpha"] = float(r["alpha"])
        if r.get("steps"):
            rec["steps"] = r["steps"]
        for entry in r["references"]:     # held out (alone) or in the data
            check = entry.get("check") or {}
            rec[f"{entry['method']}_fired"] = check.get("fired")
            rec[f"{entry['method']}_z"] = entry.get("z")
            rec[f"{entry['method']}_p"] = check.get("p_value")
        rec["flagged"] = any(rec.get(f"{m}_fired") for m in ("pulse-echo", "dma"))
        out["sources"][source] = rec
    out["wall_s"] = time.perf_counter() - t0
    return out


def _fmt(x: float) -> str:
    return "   –" if x is None or not math.isfinite(x) else f"{x:4.2f}"


def table(results: list[dict[str, Any]]) -> str:
    """One row per kind: per source E's coverage, covered-or-flagged (flagged: a check of that fit
    fired: a held-out reference disagrees, or a reference in the data is not described), mean sd
    (% of the truth) and bias (%); then how often each held-out check fires on the test alone."""
    sources = list(dict.fromkeys(s for r in results for s in r["sources"]))
    kinds = list(dict.fromkeys(r["kind"] for r in results))
    head = f"{'kind':<20}{'n':>3}" + "".join(f" | {s:<24}" for s in sources)
    head += " | checks held out: pulse-echo, DMA, either"
    sub = f"{'':<23}" + "".join(" | cover c|f   sd%  bias%" for _ in sources)
    lines = [head, sub]
    for kind in kinds:
        rs = [r for r in results if r["kind"] == kind]
        n = len(rs)
        row = f"{kind:<20}{n:>3}"
        for s in sources:
            ok = [(r, r["sources"][s]) for r in rs if "error" not in r["sources"].get(s, {"error": 1})]
            cov = sum(x["covered"] for _, x in ok) / n
            cf = sum(x["covered"] or x.get("flagged", False) for _, x in ok) / n
            sdp = np.mean([100 * x["sd"] / r["truth_E"] for r, x in ok]) if ok else math.nan
            bias = np.mean([100 * (x["E"] / r["truth_E"] - 1) for r, x in ok]) if ok else math.nan
            row += f" | {cov:5.2f} {cf:4.2f} {sdp:5.2f} {bias:+6.1f}"
        alone = [r["sources"].get("alone", {}) for r in rs]
        pe = sum(bool(a.get("pulse-echo_fired")) for a in alone) / n
        dm = sum(bool(a.get("dma_fired")) for a in alone) / n
        either = sum(bool(a.get("flagged")) for a in alone) / n
        row += f" | {pe:4.2f} {dm:4.2f} {either:4.2f}"
        failed = sum("error" in x for r in rs for x in r["sources"].values())
        if failed:
            row += f" ({failed} fits failed)"
        lines.append(row)
    alpha = [(r["kind"], r["sources"]["+DMA, alpha free"].get("alpha")) for r in results
             if "+DMA, alpha free" in r["sources"]]
    if alpha:
        lines.append("alpha with the sweep in the data (mean over replicates): " + ", ".join(
            f"{k} {np.mean([a for kk, a in alpha if kk == k and a is not None]):.3f}"
            for k in dict.fromkeys(k for k, _ in alpha)))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ms = _misspecification()
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--replicates", type=int, default=30)
    ap.add_argument("--kinds", nargs="+", choices=list(ms.ALL_KINDS), default=None)
    ap.add_argument("--strength", default="mild")
    ap.add_argument("--alpha-free", action="store_true", help="also the sweep with alpha free")
    ap.add_argument("--posterior", action="store_true",
                    help="sample every source (summary.json: the posterior's interval and checks) "
                         "instead of the linearized fit; slow")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--first", type=int, default=0)
    ap.add_argument("--out", type=Path, default=None, help="write every replicate's record (JSON)")
    ap.add_argument("--from", dest="source", type=Path, default=None)
    args = ap.parse_args(argv)
    if args.source is not None:
        print(table(json.loads(args.source.read_text())))
        return 0
    kinds = args.kinds or list(ms.KINDS)
    print(f"{len(kinds)} kinds × {args.replicates} replicates, strength {args.strength}; pulse-echo "
          f"{PE_RELATIVE_SD:.1%} at {PE_FREQUENCY:g} Hz, DMA {DMA_TRUTH['frequency_min']:g}-"
          f"{DMA_TRUTH['frequency_max']:g} Hz at {DMA_RELATIVE_SD:.0%}; jobs {args.jobs}")
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        work = [(tmp, k, args.strength, args.first + r, args.alpha_free, args.posterior) for k in kinds
                for r in range(args.replicates)]
        if args.jobs <= 1:
            results = [replicate(w) for w in work]
        else:
            import multiprocessing as mp
            from concurrent.futures import ProcessPoolExecutor

            with ProcessPoolExecutor(args.jobs, mp_context=mp.get_context("spawn")) as pool:
                results = list(pool.map(replicate, work))
    if args.out is not None:
        args.out.write_text(json.dumps(results, indent=1, default=float))
    print(table(results))
    print(f"wall time {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(HERE.parent))
    sys.exit(main())
