"""The one rule for where a test turns (data/cycles.py) on real and synthetic tests: how far each
test is from the rule's thresholds, on the side it should be.

    .venv/bin/python benchmarks/turning_points.py

An unloading is a fall of the stress by more than UNLOAD (0.5) of its value at the peak and FLOOR
(0.1) of the test's largest stress, while the strain goes back by more than BACK (0.02) of its
range. Per test this prints the peaks found and, over them, the smallest stress fall (share of the
peak's stress), the smallest fall over the largest stress and the smallest strain reversal (share of
the range): the margins above the thresholds of a test that unloads. For a test found without
unloading, the same three numbers at its deepest fall of the stress from a running maximum (a hold's
relaxation, a break), with the largest reversal of the strain anywhere: the margins below them.

Real: the ETFE film's exports (the 20 °C cyclic and relaxation specimens when present,
tests/support/real_data.py; the 40 °C tensile specimens and the rHDPE curve of ../shared/data/real)
and the biaxial inflation of the film. Synthetic: ``simulate``'s cycles (each unloading until the
stress falls to a target), cycles at large strain whose strain goes back by 4 % and 1.5 % of its
range, a ramp and a hold whose stress relaxes by 96 % while its DIC strain wanders, the shipped
ramp-and-hold example, and a tensile test to a break.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from bayes_dnlr.data.cycles import BACK, FLOOR, UNLOAD, turning_points  # noqa: E402
from bayes_dnlr.model import simulate  # noqa: E402


def margins(strain: np.ndarray, stress: np.ndarray) -> tuple[int, float, float, float, float]:
    """(peaks found, smallest fall / peak stress, smallest fall / largest stress, smallest strain
    reversal / range, largest strain reversal / range): over the unloadings found, or at the
    deepest fall of the stress when none is."""
    ok = np.isfinite(strain) & np.isfinite(stress)
    e, s = strain[ok], stress[ok]
    turns = turning_points(e, s)
    top, span = float(np.max(s)), float(np.ptp(e))
    back_any = float(np.max(np.maximum.accumulate(e) - e)) / span
    if turns.peaks:
        falls, tops, backs = [], [], []
        for n, p in enumerate(turns.peaks):
            lo = turns.valleys[n - 1] if n else 0
            nxt = turns.valleys[n] if n < len(turns.valleys) else e.size - 1
            seg = slice(p, max(nxt, p + 1) + 1)
            peak_stress = float(np.max(s[lo:p + 1]))
            fall = peak_stress - float(np.min(s[seg]))
            falls.append(fall / peak_stress)
            tops.append(fall / top)
            backs.append(float(e[p] - np.min(e[seg])) / span)
        return len(turns.peaks), min(falls), min(tops), min(backs), back_any
    run = np.maximum.accumulate(s)
    share = np.where(run > FLOOR * top, (run - s) / np.where(run > 0, run, 1.0), 0.0)
    i = int(np.argmax(share))
    k = int(np.argmax(s[:i + 1]))
    back = float(np.max(e[k:i + 1]) - e[i]) / span
    return 0, float(share[i]), float((run[i] - s[i]) / top), max(back, 0.0), back_any


def _columns(path: Path, width: int, cols: tuple[int, int], specimen: int, header: bool,
             scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    raw = np.genfromtxt(path, delimiter=",", skip_header=1 if header else 0)
    a = width * (specimen - 1)
    return raw[:, a + cols[0]] * scale, raw[:, a + cols[1]]


def real_tests() -> list[tuple[str, np.ndarray, np.ndarray]]:
    from support.real_data import CYCLES, ETFE, EXPORTS, RELAX, RHDPE

    out = []
    for spec in range(1, 7):
        if CYCLES.is_file():
            out.append((f"ETFE cyclic 20 °C #{spec}", *_columns(CYCLES, 8, (1, 3), spec, True)))
    for spec in range(1, 4):
        if RELAX.is_file():
            out.append((f"ETFE relaxation 20 °C #{spec}", *_columns(RELAX, 9, (1, 7), spec, True)))
    for spec in range(1, 4):
        if ETFE.is_file():
            out.append((f"ETFE tensile 40 °C #{spec}", *_columns(ETFE, 15, (1, 3), spec, False)))
    if RHDPE.is_file():
        raw = np.genfromtxt(RHDPE, delimiter=",")
        out.append(("rHDPE tensile to break", raw[:, 5] / 100.0, raw[:, 3]))
    biaxial = EXPORTS / "OUTRaw_ELLI_TD_T25_SR001.csv"
    if biaxial.is_file():
        for spec in range(1, 4):
            out.append((f"ETFE biaxial inflation #{spec}", *_columns(biaxial, 13, (4, 6), spec, True)))
    return out


def _plastic(back: float) -> tuple[np.ndarray, np.ndarray]:
    """tests/support/plastic_cycles.py's cycles (E 1000 MPa, flow at 20 MPa) with 0.05 MPa noise."""
    from support.plastic_cycles import plastic_cycles

    _, e, s = plastic_cycles(back=back)
    return e, s + np.random.default_rng(1).normal(0, 0.05, e.size)


def synthetic_tests() -> list[tuple[str, np.ndarray, np.ndarray]]:
    from support.export_corpus import HDPE

    from bayes_dnlr.config.run_sections import TruthConfig
    from bayes_dnlr.workflows.simulate import cyclic_protocol

    out = []
    # the HDPE of the paper peaks at about 6 MPa here: unloaded to 0, 2.5 and 4 MPa
    for target, count, top in ((0.0, 3, 0.03), (0.0, 10, 0.02), (2.5, 4, 0.03), (4.0, 4, 0.03)):
        truth = TruthConfig(params=HDPE, strain_rate=1e-3, strain_max=top, sample_rate=10.0,
                            cycles={"count": count, "unload_stress": target}, seed=3)
        rng = np.random.default_rng(3)
        p = cyclic_protocol(truth, rng, lambda t, e: simulate(t, e, HDPE))
        s = simulate(p.time, p.strain, HDPE) + rng.normal(0.0, 0.05, p.time.size)
        out.append((f"simulate: {count} cycles to {top:g}, unloaded to {target:g} MPa", p.strain, s))
    for back in (0.02, 0.0075):
        out.append((f"large-strain cycles, strain back {back / 0.5:.1%} of range", *_plastic(back)))
    rng = np.random.default_rng(3)
    t = np.concatenate((np.linspace(0, 8, 41), np.linspace(8.2, 3000, 400)))
    e = np.minimum(t / 8, 1.0) * 0.0077 + np.convolve(rng.normal(0, 6e-5, t.size + 8), np.ones(9) / 3,
                                                     mode="valid") * (t > 0)
    params = {"E": 1200.0, "G": 1.0, "tau_max": 60.0}
    s = simulate(t, np.minimum(t / 8, 1.0) * 0.0077, params) + rng.normal(0, 0.01, t.size)
    out.append(("ramp and a 3000 s hold (G 1 MPa), DIC strain wander", e, s))
    shipped = ROOT / "runs/hdpe-b-relax-5e-3/hdpe-b-relax-5e-3.csv"
    _, strain, force = np.loadtxt(shipped, delimiter=",", skiprows=1).T
    out.append(("runs/hdpe-b-relax-5e-3: ramp and a 600 s hold", strain, force))
    e = np.linspace(0, 0.3, 600)
    s = 30 * (1 - np.exp(-e / 0.02)) * np.where(e < 0.25, 1.0, np.exp(-(e - 0.25) / 0.01))
    out.append(("tensile test to a break", e, s))
    return out


def main() -> None:
    print(f"thresholds: stress fall > {UNLOAD} of the peak's stress and > {FLOOR} of the largest; "
          f"strain back > {BACK} of its range\n")
    print(f"{'test':>52} | peaks | fall/peak | fall/top | back/range | largest back anywhere")
    for group, tests in (("real", real_tests()), ("synthetic", synthetic_tests())):
        print(f"-- {group}")
        for name, e, s in tests:
            n, fall, top, back, anywhere = margins(np.asarray(e, float), np.asarray(s, float))
            print(f"{name:>52} | {n:>5} | {fall:>9.3f} | {top:>8.3f} | {back:>10.4f} | {anywhere:.4f}")


if __name__ == "__main__":
    main()
