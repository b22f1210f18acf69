"""``simulate`` for the references of a run: each DMA sweep of ``reference_moduli`` that has a
``truth:`` is written from the run's truth (the same parameters and model form as its tensile
test), and each point is set beside the truth's value at its time scale.

A sweep holds E'(ω) and E''(ω) of the generating model (workflows/truth_forms.py: the fitted
model's spectrum, or the richer one of ``truth.model_form``) at log-spaced frequencies, each times
(1 + relative_sd z), z standard normal from ``numpy.random.default_rng(seed)`` (E' first, then
E''). The file looks like a plain CSV or like the export of a TA Instruments TRIOS, Netzsch or
Anton Paar instrument (``truth.layout``), so that the reader (data/dma.py) is tried on each.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from bayes_dnlr.config import Config, ConfigError
from bayes_dnlr.numbers import frequency_text
from bayes_dnlr.workflows.simulate import write_unless_same
from bayes_dnlr.workflows.truth_forms import complex_modulus, relaxation_modulus

PA_PER_MPA = 1e6


def frequencies(t) -> np.ndarray:
    """Log-spaced frequencies (Hz) from ``frequency_min`` to ``frequency_max``, ``points_per_decade``."""
    decades = math.log10(t.frequency_max / t.frequency_min)
    n = max(2, int(round(decades * t.points_per_decade)) + 1)
    return np.geomspace(t.frequency_min, t.frequency_max, n)


def _number(x: float, decimal: str = ".") -> str:
    text = f"{x:.8g}"
    return text.replace(".", decimal) if decimal != "." else text


def sweep_bytes(freq: np.ndarray, storage: np.ndarray, loss: np.ndarray, temperature: float | None,
                layout: str) -> bytes:
    """The text of a sweep file in ``layout`` (plain, trios, netzsch, anton-paar); moduli in MPa
    given, written in each layout's own unit."""
    temp = [] if temperature is None else [float(temperature)] * freq.size
    tan = loss / storage
    lines: list[str] = []
    if layout == "plain":
        head = ["frequency (Hz)", "storage modulus (MPa)", "loss modulus (MPa)"] + (
            ["temperature (°C)"] if temp else [])
        lines.append(",".join(head))
        for i in range(freq.size):
            row = [freq[i], storage[i], loss[i]] + ([temp[i]] if temp else [])
            lines.append(",".join(_number(x) for x in row))
    elif layout == "trios":
        lines += ["Filename\tsweep.tri", "Instrument name\tDMA (simulated by bayes_dnlr)",
                  "Geometry\tTension: film", "", "[step]", "Frequency sweep - 1"]
        lines.append("\t".join(["Frequency", "Storage modulus", "Loss modulus", "Tan(delta)"]
                               + (["Temperature"] if temp else [])))
        lines.append("\t".join(["Hz", "MPa", "MPa", ""] + (["°C"] if temp else [])))
        for i in range(freq.size):
            row = [freq[i], storage[i], loss[i], tan[i]] + ([temp[i]] if temp else [])
            lines.append("\t".join(_number(x) for x in row))
    elif layout == "netzsch":
        lines += ["#EXPORTTYPE:;DATA ALL", "#INSTRUMENT:;NETZSCH DMA (simulated by bayes_dnlr)",
                  "#MODE:;Tension", "#SEGMENT:;S1/1: frequency sweep"]
        lines.append(";".join((["##Temp./°C"] if temp else []) + ["Frequency/Hz", "E'/MPa", "E''/MPa",
                                                                   "tan d"]))
        for i in range(freq.size):
            row = ([temp[i]] if temp else []) + [freq[i], storage[i], loss[i], tan[i]]
            lines.append(";".join(_number(x, ",") for x in row))
    elif layout == "anton-paar":
        lines += ["Project:\tbayes_dnlr simulate", "Test:\tDMA frequency sweep (tension)",
                  "Result:\tsweep 1", "", f"Interval and data points:\t1\t{freq.size}"]
        lines.append("\t".join(["Interval data:", "Point No.", "Frequency", "Storage Modulus",
                                "Loss Modulus", "Loss Factor"] + (["Temperature"] if temp else [])))
        lines.append("\t".join(["", "", "[Hz]", "[Pa]", "[Pa]", "[1]"] + (["[°C]"] if temp else [])))
        for i in range(freq.size):
            row = [freq[i], storage[i] * PA_PER_MPA, loss[i] * PA_PER_MPA, tan[i]] + (
                [temp[i]] if temp else [])
            lines.append("\t".join(["", str(i + 1)] + [_number(x) for x in row]))
    else:
        raise ValueError(f"unknown sweep layout {layout!r}")
    return ("\n".join(lines) + "\n").encode("utf-8")


def _truth_of(cfg: Config, entry, i: int):
    """The run's truth a reference comes from: its test's, else the one test's (or the first with
    the model's parameters)."""
    if entry.test is not None:
        truth = cfg.for_test(entry.test).truth
    elif cfg.tests is None:
        truth = cfg.truth
    else:
        truth = next((v.truth for v in cfg.test_configs() if v.truth is not None), None)
    if truth is None:
        where = cfg.source if cfg.source is not None else "config"
        raise ConfigError(f"{where}: reference_moduli[{i}]: simulate needs the run's truth: (its "
                          "parameters and model form)")
    return truth


def _form(truth) -> tuple[str | None, str | float]:
    form = truth.model_form
    return (None, "mild") if form is None else (form.kind, form.strength)


def simulate_references(cfg: Config, overwrite: bool = False) -> list[str]:
    """Write every sweep with a ``truth:`` and compare every point with the truth; the lines to
    print."""
    out = []
    labels = cfg.reference_labels
    for i, e in enumerate(cfg.reference_moduli or []):
        if e.is_sweep and e.truth is None:
            continue
        if not e.is_sweep and e.frequency is None and e.time is None:
            continue
        truth = _truth_of(cfg, e, i)
        kind, strength = _form(truth)
        modes, decades = cfg.model.modes, cfg.model.decades
        if not e.is_sweep:
            if e.frequency is not None:
                true = float(complex_modulus(e.frequency, truth.params, kind, strength, modes,
                                             decades)[0][0])
                at = f"E'({frequency_text(e.frequency)})"
            else:
                true = float(relaxation_modulus(e.time, truth.params, kind, strength, modes, decades)[0])
                at = f"E(t = {e.time:g} s)"
            sd = e.value_sd()
            z = f", {(e.value - true) / sd:+.2f} sd" if sd else ""
            out.append(f"reference_moduli[{i}] ({labels[i]}): the truth's {at} = {true:.6g} MPa; the "
                       f"config gives {e.value:g}{f' ± {sd:g}' if sd else ''} MPa ({e.value - true:+.4g}{z})")
            continue
        t = e.truth
        f = frequencies(t)
        storage, loss = complex_modulus(f, truth.params, kind, strength, modes, decades)
        rng = np.random.default_rng(t.seed)
        storage = storage * (1.0 + t.relative_sd * rng.standard_normal(f.size))
        loss = loss * (1.0 + t.relative_sd * rng.standard_normal(f.size))
        path = Path(e.file)
        path = path if path.is_absolute() else cfg.base_dir / path
        data = sweep_bytes(f, storage, loss, t.temperature, t.layout)
        status, notes = write_unless_same(path, data, overwrite, cfg.source or "the config")
        out.append(f"reference_moduli[{i}] ({labels[i]}): {path}: {status}: a DMA sweep of {f.size} "
                   f"frequencies, {f[0]:g}-{f[-1]:g} Hz, E' {storage.min():.5g}-{storage.max():.5g} MPa, "
                   f"noise {100 * t.relative_sd:g} % (seed {t.seed}), {t.layout} layout"
                   + "".join(f"; {n}" for n in notes))
    return out
