"""A corpus of machine exports in real layouts, made by the package itself (the DNLR model of
bayes_dnlr.model with the paper's HDPE parameters, plus noise): a header shifted against its data
(by four empty cells, or by one column inside each specimen's group, the names then contradicting
the values), specimens side by side with indexed names, a ramp-plus-hold, both stresses in one
file, force + extension + strain without a header, a decimal comma with a units row, repeated time
stamps, loading-unloading cycles (``simulate``'s cyclic protocol), an engineering stress as the only
stress.

Each case gives the file, what ``init`` must find in it (``expect``) and the config an engineer who
knows the layout writes by hand (``hand``); ``set`` holds the values init may ask for (area0 for a
force, which no export holds). The stress columns obey the relations of data/relations.py to the
10 significant digits written: the true stress is the engineering stress × (1 + e), the engineering
stress is F/S0, the Hencky strain is ln(1 + e), the extension is L0·e.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from bayes_dnlr.config.run_sections import TruthConfig
from bayes_dnlr.model import simulate
from bayes_dnlr.workflows.simulate import cyclic_protocol

HDPE = {"E": 2854.0, "G": 2.32, "tau_max": 5.79}
RELAX = {**HDPE, "sigma_inf": 20.0, "tau_max_R": 20.0}
SPEED = 50.0 / 60.0           # mm/s: 50 mm/min, a standard crosshead speed
GAUGE = 115.0                 # mm: the grip distance of an ISO 527-2 type 1A bar
S0 = 40.0                     # mm²


@dataclass
class Case:
    name: str
    path: Path
    expect: dict[str, Any]                    # data keys init must write, as written
    hand: dict[str, Any]                      # the hand-written data section (file relative to it)
    set: dict[str, Any] = field(default_factory=dict)   # values init lists as 'set'
    peak_time: float | None = None            # the load peak (the window ends there)


def _num(x: float) -> str:
    return f"{x:.10g}"


def _rows(columns: list[np.ndarray], sep: str = ",", decimal: str = ".") -> list[str]:
    out = []
    for row in zip(*columns, strict=True):
        cells = [_num(float(v)) for v in row]
        out.append(sep.join(c.replace(".", decimal) for c in cells))
    return out


def _ramp(n: int, e_max: float, seed: int, hold: float = 0.0, rate: float = SPEED / GAUGE,
          params: dict | None = None, stress_sd: float = 0.1) -> dict[str, np.ndarray]:
    """A test at constant crosshead speed (nominal strain rate ``rate``) to ``e_max``, then a hold
    of ``hold`` s: time, nominal strain e, Hencky strain, true stress (model + noise), engineering
    stress, force."""
    ramp = e_max / rate
    t = np.linspace(0.0, ramp + hold, n)
    t[np.argmin(np.abs(t - ramp))] = ramp                   # the kink on a sample
    e = np.minimum(rate * t, e_max)
    eps = np.log1p(e)
    rs = ramp if hold else None
    true = simulate(t, eps, params or (RELAX if hold else HDPE), relaxation_start=rs)
    true = true + np.random.default_rng(seed).normal(0.0, stress_sd, n)
    true[0] = 0.0
    eng = true / (1.0 + e)
    return {"t": t, "e": e, "eps": eps, "true": eng * (1.0 + e), "eng": eng, "force": eng * S0}


def _peak(d: dict[str, np.ndarray]) -> float:
    """The time of the engineering stress's peak, as written in the file."""
    return float(_num(float(d["t"][int(np.argmax(d["eng"]))])))


def shifted_relax(folder: Path) -> Case:
    """Three specimens, tensile then relaxation, five columns each (time, extension, strain in %,
    engineering stress, true stress); the header has four empty cells after its fifth, so from the
    sixth on its names sit four columns right of their data."""
    specs = [_ramp(400, 0.3, seed, hold=60.0) for seed in (1, 2, 3)]
    header = []
    cols = []
    for k, d in enumerate(specs, 1):
        header += [f"Time {k} (s)", f"Extension {k} (mm)", f"Strain {k} (%)", f"Stress {k} (MPa)",
                   f"True stress {k} (MPa)"]
        if k == 1:
            header += ["", "", "", ""]
        cols += [d["t"], GAUGE * d["e"], 100 * d["e"], d["eng"], d["true"]]
    path = folder / "relax-3-specimens.csv"
    path.write_text("\n".join([",".join(header), *_rows(cols)]) + "\n")
    data = {"specimen": 1, "specimen_columns": 5, "columns": {"time": 1, "strain": 3, "stress": 5},
            "strain_unit": "percent", "strain_measure": "nominal", "observable": "stress",
            "relaxation_start": "auto", "window": {}}
    return Case("shifted-relax", path, data, {**data, "units": {"time": "s", "stress": "MPa"}})


def indexed_force(folder: Path) -> Case:
    """Two specimens side by side, names with an index (Time_1, Load_1, Strain_1), a tensile test
    to past the load peak: the force needs area0."""
    specs = [_ramp(480, 0.4, seed) for seed in (4, 5)]
    header, cols = [], []
    for k, d in enumerate(specs, 1):
        header += [f"Time_{k} (s)", f"Load_{k} (N)", f"Strain_{k} (%)"]
        cols += [d["t"], d["force"], 100 * d["e"]]
    path = folder / "two-specimens.csv"
    path.write_text("\n".join([",".join(header), *_rows(cols)]) + "\n")
    expect = {"specimen": 1, "specimen_columns": 3, "columns": {"time": 1, "force": 2, "strain": 3}}
    hand = {**expect, "area0": S0, "strain_measure": "nominal", "window": {"time_max": _peak(specs[0])}}
    return Case("indexed-force", path, expect, hand, {"data.area0": S0}, _peak(specs[0]))


def both_stresses(folder: Path) -> Case:
    """No header, one specimen, the layout of a DIC export: time, nominal strain, Hencky strain,
    engineering stress, true stress, transverse strain, at a constant true strain rate."""
    rate = 5e-3
    t = np.linspace(0.0, 0.6 / rate, 600)
    eps = rate * t
    e = np.expm1(eps)
    true = simulate(t, eps, HDPE) + np.random.default_rng(6).normal(0.0, 0.1, t.size)
    true[0] = 0.0
    eng = true / (1.0 + e)
    cols = [t, e, np.log1p(e), eng, eng * (1.0 + e), -0.5 * e]
    path = folder / "dic-export.csv"
    path.write_text("\n".join(_rows(cols)) + "\n")
    peak = _peak({"t": t, "eng": eng})
    data = {"columns": {"time": 1, "strain": 3, "stress": 5}, "strain_unit": "fraction",
            "strain_measure": "hencky", "observable": "stress"}
    return Case("both-stresses", path, data, {**data, "window": {"time_max": peak}}, peak_time=peak)


def force_extension_strain(folder: Path) -> Case:
    """No header, the layout of a crosshead test: index, time, extension (mm), force (N),
    engineering stress (MPa), strain (%), at 50 mm/min on a 115 mm gauge length."""
    d = _ramp(480, 0.4, 7)
    cols = [np.arange(1, d["t"].size + 1), d["t"], GAUGE * d["e"], d["force"], d["eng"], 100 * d["e"]]
    path = folder / "crosshead-export.csv"
    path.write_text("\n".join(_rows(cols)) + "\n")
    data = {"columns": {"time": 2, "force": 4, "strain": 6}, "strain_unit": "percent", "area0": S0,
            "strain_measure": "nominal"}
    return Case("force-extension-strain", path, data, {**data, "window": {"time_max": _peak(d)}},
                peak_time=_peak(d))


def ramp_hold_plain(folder: Path) -> Case:
    """No header, one specimen, a ramp then a hold: time, strain (fraction), force (N)."""
    d = _ramp(500, 0.3, 8, hold=60.0)
    path = folder / "ramp-hold.csv"
    path.write_text("\n".join(_rows([d["t"], d["e"], d["force"]])) + "\n")
    expect = {"columns": {"time": 1, "force": 3, "strain": 2}, "relaxation_start": "auto", "window": {}}
    hand = {**expect, "area0": S0, "strain_unit": "fraction", "strain_measure": "nominal"}
    return Case("ramp-hold-plain", path, expect, hand, {"data.area0": S0})


def zwick_both(folder: Path) -> Case:
    """';' and a decimal comma, a metadata block, a German header and a units row; both the
    engineering and the true stress: the names alone do not tell which to use, the relation does."""
    d = _ramp(480, 0.4, 9)
    meta = ["Prüfprotokoll;Probe 7", "Werkstoff;PE-HD", ""]
    header = ["Prüfzeit;Dehnung;Spannung;Wahre Spannung", "s;%;MPa;MPa"]
    body = _rows([d["t"], 100 * d["e"], d["eng"], d["true"]], sep=";", decimal=",")
    path = folder / "zwick-both.csv"
    path.write_text("\n".join([*meta, *header, *body]) + "\n", encoding="utf-8")
    data = {"columns": {"time": "Prüfzeit", "strain": "Dehnung", "stress": "Wahre Spannung"},
            "strain_measure": "nominal", "observable": "stress"}
    return Case("zwick-both", path, data, {**data, "window": {"time_max": _peak(d)}}, peak_time=_peak(d))


def _dic_relax(seed: int, e_max: float = 0.01, rate: float = 1e-3, hold: float = 300.0
               ) -> dict[str, np.ndarray]:
    """A ramp at a constant nominal strain rate to a small strain, then a long hold, as a DIC export
    writes it: the strain measured with a slow wander (sd 0.4 % of the strain in the hold), the
    stress written to 10 digits."""
    rng = np.random.default_rng(seed)
    ramp = e_max / rate
    t = np.concatenate((np.linspace(0.0, ramp, 51), ramp + np.linspace(0.0, hold, 301)[1:]))
    e = np.minimum(rate * t, e_max)
    true = simulate(t, np.log1p(e), {**HDPE, "sigma_inf": 4.0, "tau_max_R": 60.0}, relaxation_start=ramp)
    true = true + rng.normal(0.0, 0.02, t.size)
    true[0] = 0.0
    wander = np.convolve(rng.normal(0.0, 1.0, t.size + 8), np.ones(9) / 3.0, mode="valid")
    measured = e + 0.004 * e_max * wander * (t > 0)
    eng = true / (1.0 + measured)
    return {"t": t, "e": measured, "true": eng * (1.0 + measured), "eng": eng,
            "eps_other": np.log1p(e) + rng.normal(0.0, 2e-5, t.size) * (t > 0)}


def shifted_by_one(folder: Path) -> Case:
    """Three specimens of a ramp then a hold at 1 % strain, nine columns each as a DIC export
    writes them (time, nominal strain, engineering stress, transverse strain, a column of zeros, the
    time again, a second Hencky strain, the true stress, the strain rate); the header names each
    group's sixth column on: the name of the Hencky strain stands over the time's copy, the name of
    the true stress over the Hencky strain, a strain-rate name over the true stress. Only the
    relation true = engineering × (1 + e), to the 10 digits written, tells the true stress."""
    specs = [_dic_relax(seed) for seed in (11, 12, 13)]
    header, cols = [], []
    for k, d in enumerate(specs, 1):
        header += [f"t{k:02d}", f"exxEng{k:02d}AVG", f"StressEng{k:02d}AVG", f"eyyEng{k:02d}AVG", "0",
                   f"exxHencky{k:02d}SOI", f"StressTrue{k:02d}AVG", f"SR{k}HenckyAVG", f"eyyHencky{k:02d}AVG"]
        rate = np.gradient(d["eps_other"], d["t"])
        cols += [d["t"], d["e"], d["eng"], -0.4 * d["e"], 0.0 * d["t"], d["t"], d["eps_other"], d["true"],
                 rate]
    path = folder / "dic-relax-shifted.csv"
    path.write_text("\n".join([",".join(header), *_rows(cols)]) + "\n")
    data = {"specimen": 1, "specimen_columns": 9, "columns": {"time": 1, "strain": 2, "stress": 8},
            "strain_unit": "fraction", "strain_measure": "nominal", "observable": "stress",
            "relaxation_start": "auto", "window": {}}
    return Case("shifted-by-one", path, data, data)


def _crosshead(seed: int, repeats: tuple[int, ...]) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """A crosshead test to past the load peak, and the rows a logger writes twice (their index in
    the file, the original row kept before each)."""
    d = _ramp(480, 0.4, seed)
    rows = np.sort(np.concatenate((np.arange(d["t"].size), np.asarray(repeats))))
    return d, rows


def repeated_stamps(folder: Path) -> Case:
    """One specimen (time, strain in %, force) whose logger writes some rows twice: the same time
    stamp and the same values on two lines, as the real cyclic exports have them."""
    d, rows = _crosshead(14, (1, 37, 212, 300))
    header = "Time (s),Strain (%),Force (N)"
    path = folder / "repeated-stamps.csv"
    path.write_text("\n".join([header, *_rows([d["t"][rows], 100 * d["e"][rows], d["force"][rows]])]) + "\n")
    expect = {"columns": {"time": "Time (s)", "force": "Force (N)", "strain": "Strain (%)"},
              "repeated_time": "drop"}
    hand = {**expect, "area0": S0, "strain_measure": "nominal", "window": {"time_max": _peak(d)}}
    return Case("repeated-stamps", path, expect, hand, {"data.area0": S0}, _peak(d))


def _first_peak(t: np.ndarray, strain: np.ndarray) -> float:
    """The time of the strain's first peak, as written in the file: where the first loading ends."""
    return float(_num(float(t[int(np.flatnonzero(np.diff(strain) < 0)[0])])))


def _cycles(seed: int, count: int = 3, strain_max: float = 0.03, rate: float = 1e-3,
            sample_rate: float = 2.0) -> dict[str, np.ndarray]:
    """Loading-unloading cycles by ``simulate``'s protocol (each unloading until the stress falls
    to zero), the true stress of the DNLR model plus noise, the engineering stress and the nominal
    strain of it."""
    truth = TruthConfig(params=HDPE, strain_rate=rate, strain_max=strain_max, sample_rate=sample_rate,
                        cycles={"count": count, "unload_stress": 0.0}, seed=seed)
    rng = np.random.default_rng(seed)
    p = cyclic_protocol(truth, rng, lambda t, e: simulate(t, e, HDPE))
    true = simulate(p.time, p.strain, HDPE) + rng.normal(0.0, 0.05, p.time.size)
    true[0] = 0.0
    e = np.expm1(p.strain)
    eng = true / (1.0 + e)
    return {"t": p.time, "e": e, "eps": p.strain, "true": eng * (1.0 + e), "eng": eng}


def cycles_true_stress(folder: Path) -> Case:
    """One specimen, three loading-unloading cycles at 1e-3 1/s to 1, 2 and 3 % strain, sampled at
    2 Hz: time, Hencky strain, true stress. The turning points are sparse samples, no spikes; the
    window is the first loading."""
    d = _cycles(15)
    path = folder / "cycles.csv"
    path.write_text("\n".join(["Time (s),True strain,True stress (MPa)",
                               *_rows([d["t"], d["eps"], d["true"]])]) + "\n")
    data = {"columns": {"time": "Time (s)", "stress": "True stress (MPa)", "strain": "True strain"},
            "strain_measure": "hencky", "observable": "stress"}
    peak = _first_peak(d["t"], d["eps"])
    return Case("cycles", path, data, {**data, "window": {"time_max": peak}}, peak_time=peak)


def engineering_only(folder: Path) -> Case:
    """Three specimens of loading-unloading cycles side by side, eight columns each as the cyclic
    DIC exports write them (time, axial strain of a point and of an area, the engineering stress,
    transverse and shear strains); the engineering stress is the only stress, said by its name; the
    logger wrote a row of each specimen twice, with the same time stamp and new values."""
    specs = [_cycles(seed, count=2, strain_max=0.02) for seed in (16, 17, 18)]
    n = max(d["t"].size for d in specs)
    header, cols = [], []
    for k, d in enumerate(specs, 1):
        header += [f"t{k:02d}", f"exxEng{k:02d}SOI", f"exxEng{k:02d}AVG", f"StressEng{k:02d}SOI",
                   f"eyyEng{k:02d}SOI", f"eyyEng{k:02d}AVG", f"exyEng{k:02d}SOI", f"exyEng{k:02d}AVG"]
        t, e, eng = d["t"].copy(), d["e"].copy(), d["eng"].copy()
        t = np.insert(t, 2, t[1])                        # the logger's repeat: line 4 has line 3's time
        e = np.insert(e, 2, 1.01 * e[1])
        eng = np.insert(eng, 2, 1.01 * eng[1])
        pad = n + 1 - t.size                             # shorter specimens are padded with NaN
        rng = np.random.default_rng(k)                  # the area's strain: the point's, other noise
        avg = e + rng.normal(0.0, 2e-5, e.size) * (t > 0)
        group = [t, e, avg, eng, -0.4 * e, -0.4 * avg, 0.0 * e, 0.0 * e]
        cols += [np.concatenate((g, np.full(pad, np.nan))) for g in group]
    path = folder / "cycles-engineering.csv"
    path.write_text("\n".join([",".join(header), *_rows(cols)]).replace("nan", "") + "\n")
    data = {"specimen": 1, "specimen_columns": 8, "columns": {"time": 1, "stress": 4, "strain": 2},
            "repeated_time": "drop", "strain_unit": "fraction", "observable": "stress",
            "stress_measure": "engineering", "strain_measure": "nominal"}
    peak = _first_peak(specs[0]["t"], specs[0]["e"])
    return Case("engineering-only", path, data, {**data, "window": {"time_max": peak}}, peak_time=peak)


CASES: dict[str, Callable[[Path], Case]] = {
    "shifted-relax": shifted_relax, "indexed-force": indexed_force, "both-stresses": both_stresses,
    "force-extension-strain": force_extension_strain, "ramp-hold-plain": ramp_hold_plain,
    "zwick-both": zwick_both, "shifted-by-one": shifted_by_one, "repeated-stamps": repeated_stamps,
    "cycles": cycles_true_stress, "engineering-only": engineering_only,
}
