"""Synthetic tests: ``simulate_test(cfg)`` writes the CSV that ``cfg.data`` describes, from ``cfg.truth``.

The protocol is the paper's: a ramp at a constant true (Hencky) strain rate up to ``strain_max``,
then optionally a hold (relaxation, section 4.1 and Fig. 10); or loading-unloading cycles
(``truth.cycles``): each cycle loads at the same rate to its peak and unloads until the stress falls
to ``unload_stress``, as a machine that reverses at a force. The true stress is the DNLR model
(eq. 18) driven by the noise-free strain; the file holds what a real test would give: the *noisy
measured* strain (Gaussian, sd ``strain_sd``), the force computed so that σ* (eq. 6) or σ (eq. 2)
from the file equals the true stress plus Gaussian noise of sd ``stress_sd``, plus ``force_sd`` on
the force. Random draws, from ``numpy.random.default_rng(seed)`` in this order: time jitter, axial
strain noise, stress noise, force noise, transverse strain noise, then the correlated error.

``truth.noise.correlated`` adds a smooth correlated error to the observable stress (a model error as
the discrepancy likelihood sees it, docs/model-error.md): a stationary Gaussian process on the time
axis, exp (Ornstein-Uhlenbeck, k = a² e^{-τ/ℓ}) or matern32 (k = a² (1 + √3τ/ℓ) e^{-√3τ/ℓ}),
drawn exactly on the (possibly non-uniform) grid in O(n) from its state-space form.

``truth.model_form`` makes the test with a richer model than the fitted one (truth_forms.py):
another spectrum shape, a stiffer hardening law, a second relaxation process, or a strain channel
that reports another strain than the specimen's (the axial column then holds that strain).
"""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bayes_dnlr.config import Config, ConfigError, TruthConfig
from bayes_dnlr.data import DataError, nominal_from_hencky
from bayes_dnlr.data.numbers import parse_cell
from bayes_dnlr.model.shift import Shift
from bayes_dnlr.units import factor
from bayes_dnlr.workflows.truth_forms import generate

FORMAT = "%.10g"
# per layout: delimiter, decimal mark, quote every cell, thousands separator, default unit per role kind
LAYOUTS = {
    "plain": {"delimiter": ",", "decimal": ".", "quote": False, "thousands": None, "units": None},
    "bluehill": {"delimiter": ",", "decimal": ".", "quote": True, "thousands": ",",
                 "units": {"time": "s", "force": "N", "stress": "MPa", "strain": "%", "length": "mm"},
                 "unit_text": "({})"},
    "zwick": {"delimiter": ";", "decimal": ",", "quote": False, "thousands": None,
              "units": {"time": "s", "force": "N", "stress": "MPa", "strain": "%", "length": "mm"},
              "unit_text": "{}"},
}
_KIND = {"time": "time", "force": "force", "stress": "stress", "eps11": "strain", "eps22": "strain",
         "strain": "strain", "extension": "length"}


@dataclass(frozen=True)
class Protocol:
    """The noise-free test: time grid, Hencky strain and the time the hold starts (or None)."""

    time: np.ndarray
    strain: np.ndarray
    relaxation_start: float | None


@dataclass(frozen=True)
class SimulationResult:
    """What ``simulate_test`` made: the file, the noise-free truth and whether it was written."""

    path: Path
    status: str                  # "written" | "up to date"
    name: str
    truth: TruthConfig
    time: np.ndarray             # s
    strain: np.ndarray           # noise-free Hencky strain
    stress: np.ndarray           # noise-free true stress, MPa
    relaxation_start: float | None
    notes: tuple[str, ...] = ()

    @property
    def n_points(self) -> int:
        return int(self.time.size)

    def considere(self) -> tuple[float, float] | None:
        """First maximum of the nominal stress σ·exp(-ε) (first Considère point): (strain, true stress)."""
        nominal = self.stress * np.exp(-self.strain)
        d = np.diff(nominal)
        peaks = np.flatnonzero((d[:-1] > 0) & (d[1:] <= 0)) + 1
        if peaks.size == 0:
            return None
        i = int(peaks[0])
        return float(self.strain[i]), float(self.stress[i])

    def summary(self) -> str:
        """A few lines for a person: file, points, duration, strain range, stresses, noise."""
        tr = self.truth
        hold = (f", then a {tr.hold:g} s hold from t = {self.relaxation_start:g} s"
                if self.relaxation_start is not None else "")
        if tr.cycles is not None:
            peaks = ", ".join(f"{p:g}" for p in tr.cycle_peaks())
            hold = (f"; {len(tr.cycle_peaks())} loading-unloading cycles to {peaks}, each unloaded "
                    f"to {tr.cycles.unload_stress:g} MPa")
        peak = self.considere()
        peak_text = ("none (the nominal stress never falls)" if peak is None else
                     f"strain {peak[0]:.4f}, true stress {peak[1]:.2f} MPa")
        params = ", ".join(f"{k} {v:g}" for k, v in tr.params.items())
        lines = [
            f"{self.name}: {_display(self.path)}: {self.status}",
            f"  {self.n_points} points over {self.time[-1] - self.time[0]:g} s (ramp at "
            f"{tr.strain_rate:g} 1/s{hold})",
            f"  strain (Hencky, noise-free) {self.strain.min():.4g} to {self.strain.max():.4g}",
            f"  true stress: max {self.stress.max():.2f} MPa, final {self.stress[-1]:.2f} MPa",
            f"  nominal-stress maximum (first Considère point): {peak_text}",
            f"  truth: {params}",
            f"  noise: strain sd {tr.noise.strain_sd:g}, stress sd {tr.noise.stress_sd:g} MPa, "
            f"force sd {tr.noise.force_sd:g} N; seed {tr.seed}",
        ]
        return "\n".join(lines + [f"  note: {n}" for n in self.notes])


def _display(path: Path) -> str:
    """The path relative to the working folder when it lies inside it, else as it is."""
    try:
        return str(path.resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path)


def _rounded(x: np.ndarray) -> np.ndarray:
    """Values as they will read back from the file (FORMAT), so the model sees the written grid."""
    return np.array([float(FORMAT % v) for v in x])


def _segment(duration: float, steps: int, jitter: float, rng: np.random.Generator) -> np.ndarray:
    """``steps`` step lengths that add up to ``duration``, each jittered by a relative ±``jitter``."""
    dt = np.ones(steps)
    if jitter > 0:
        dt *= 1.0 + rng.uniform(-jitter, jitter, steps)
    return dt * (duration / dt.sum())


def protocol(truth: TruthConfig, rng: np.random.Generator) -> Protocol:
    """Ramp at truth.strain_rate to truth.strain_max, then the hold; the kink falls on a sample.

    With n_points the samples are shared between ramp and hold in proportion to their lengths;
    with sample_rate each segment gets round(duration · rate) steps. Jitter moves the samples inside
    each segment, never the kink.
    """
    ramp = truth.strain_max / truth.strain_rate
    total = ramp + truth.hold
    if truth.n_points is not None:
        n_ramp = max(1, round((truth.n_points - 1) * ramp / total))
        n_hold = truth.n_points - 1 - n_ramp
        if truth.hold > 0 and n_hold < 1:
            raise ConfigError(f"truth.n_points {truth.n_points} leaves no sample for the hold")
    else:
        n_ramp = max(1, round(ramp * truth.sample_rate))
        n_hold = round(truth.hold * truth.sample_rate) if truth.hold > 0 else 0
        if truth.hold > 0 and n_hold < 1:
            raise ConfigError(f"truth.sample_rate {truth.sample_rate:g} Hz leaves no sample for the hold")
    steps = [_segment(ramp, n_ramp, truth.time_jitter, rng)]
    if n_hold:
        steps.append(_segment(truth.hold, n_hold, truth.time_jitter, rng))
    time = _rounded(np.concatenate([[0.0], np.cumsum(np.concatenate(steps))]))
    time[n_ramp] = float(FORMAT % ramp)  # the kink exactly on a sample
    if n_hold:
        time[-1] = float(FORMAT % total)
    if np.any(np.diff(time) <= 0):
        raise ConfigError("truth: the sampling is too fine for the file's precision (steps below 1e-9 s)")
    kink = time[n_ramp]
    strain = truth.strain_max * np.minimum(time, kink) / kink
    return Protocol(time, strain, kink if n_hold else None)


def cyclic_protocol(truth: TruthConfig, rng: np.random.Generator,
                    stress_of: Callable[[np.ndarray, np.ndarray], np.ndarray]) -> Protocol:
    """Loading-unloading cycles (``truth.cycles``) at ``truth.strain_rate``, sampled at
    ``truth.sample_rate``, every turning point on a sample.

    Each unloading runs at the loading's rate until ``stress_of(time, strain)`` (the true stress of
    the whole history so far) falls to ``unload_stress``, or the strain to zero; the sample where it
    does is the next turning point. ``stress_of`` is called once per cycle.
    """
    rate, fs = truth.strain_rate, float(truth.sample_rate)
    target = truth.cycles.unload_stress
    time, strain = np.zeros(1), np.zeros(1)

    def leg(t0: float, e0: float, e1: float) -> tuple[np.ndarray, np.ndarray]:
        duration = abs(e1 - e0) / rate
        steps = max(1, round(duration * fs))
        t = t0 + np.cumsum(_segment(duration, steps, truth.time_jitter, rng))
        t[-1] = t0 + duration                     # the turning point exactly on a sample
        return t, e0 + (e1 - e0) * (t - t0) / duration

    for peak in truth.cycle_peaks():
        if peak <= strain[-1]:
            raise ConfigError(f"truth.cycles: peak {peak:g} is not above the strain {strain[-1]:.4g} "
                              "where the previous unloading stopped")
        t_up, e_up = leg(time[-1], strain[-1], peak)
        t_dn, e_dn = leg(t_up[-1], peak, 0.0)
        t_all = np.concatenate([time, t_up, t_dn])
        e_all = np.concatenate([strain, e_up, e_dn])
        s_dn = stress_of(_rounded(t_all), e_all)[-t_dn.size:]
        below = np.flatnonzero(s_dn <= target)
        stop = int(below[0]) + 1 if below.size else t_dn.size
        time = np.concatenate([time, t_up, t_dn[:stop]])
        strain = np.concatenate([strain, e_up, e_dn[:stop]])
    time = _rounded(time)
    if np.any(np.diff(time) <= 0):
        raise ConfigError("truth: the sampling is too fine for the file's precision (steps below 1e-9 s)")
    return Protocol(time, strain, None)


def _check(cfg: Config) -> TruthConfig:
    where = cfg.source if cfg.source is not None else "config"
    truth = cfg.truth
    if truth is None:
        raise ConfigError(f"{where}: truth: section is missing: simulate needs the known parameters "
                          f"and the test protocol (see docs/data-input.md)")
    c = cfg.data.columns
    if c.time is None and (truth.hold > 0 or truth.noise.strain_sd > 0
                           or not np.isclose(cfg.data.strain_rate, truth.strain_rate, rtol=1e-12)):
        raise ConfigError(f"{where}: data.columns.time: a synthetic test without a time column must be "
                          f"a noise-free ramp (truth.noise.strain_sd 0, no hold) at data.strain_rate")
    if c.force is not None and cfg.data.area0 is None:
        raise ConfigError(f"{where}: data.area0: needed to write the force column")
    spec = LAYOUTS[truth.layout]
    d = cfg.data
    if truth.layout != "plain":
        clash = [k for k, v in (("delimiter", d.delimiter), ("decimal", d.decimal)) if v is not None
                 and v != spec[k]] + (["header: false"] if d.header is False else []) + (
                     ["format: plain"] if d.format == "plain" else [])
        if clash:
            raise ConfigError(f"{where}: truth.layout: {truth.layout} writes its own format; remove "
                              f"data.{', data.'.join(clash)}")
    if d.header is False or any(isinstance(getattr(c, r), int) for r in type(c).model_fields
                                if getattr(c, r) is not None):
        raise ConfigError(f"{where}: data.columns: simulate writes a header row and needs the columns "
                          f"by name")
    return truth


def _matern32_step(dt: float, lam: float, amplitude: float) -> tuple[np.ndarray, np.ndarray]:
    """Transition Φ and a square root of the process noise Q of the Matérn-3/2 state (f, f') over dt."""
    e = np.exp(-lam * dt)
    phi = e * np.array([[1.0 + lam * dt, dt], [-lam * lam * dt, 1.0 - lam * dt]])
    p_inf = np.diag([amplitude**2, lam**2 * amplitude**2])
    q = p_inf - phi @ p_inf @ phi.T
    l11 = np.sqrt(max(q[0, 0], 0.0))
    l21 = q[1, 0] / l11 if l11 > 0 else 0.0
    l22 = np.sqrt(max(q[1, 1] - l21 * l21, 0.0))
    return phi, np.array([[l11, 0.0], [l21, l22]])


def correlated_error(time: np.ndarray, kernel: str, amplitude: float, length: float,
                     rng: np.random.Generator, size: int | None = None) -> np.ndarray:
    """Exact draw(s) of a zero-mean stationary Gaussian process on the sorted ``time`` grid.

    kernel exp: the AR(1) recursion x_k = φ x_{k-1} + a √(1-φ²) z, φ = e^{-Δt/ℓ}; matern32: the
    2-state (f, f') recursion with Φ = e^{FΔt} and Q = P∞ - Φ P∞ Φᵀ. Shape (n,), or (size, n)."""
    t = np.asarray(time, dtype=float)
    m = 1 if size is None else int(size)
    dts = np.diff(t)
    if np.any(dts <= 0):
        raise ValueError("correlated_error needs strictly increasing times")
    out = np.empty((m, t.size))
    if kernel == "exp":
        x = amplitude * rng.standard_normal(m)
        out[:, 0] = x
        for k, dt in enumerate(dts, start=1):
            phi = np.exp(-dt / length)
            x = phi * x + amplitude * np.sqrt(-np.expm1(-2.0 * dt / length)) * rng.standard_normal(m)
            out[:, k] = x
    elif kernel == "matern32":
        lam = np.sqrt(3.0) / length
        x = rng.standard_normal((m, 2)) * np.array([amplitude, lam * amplitude])
        out[:, 0] = x[:, 0]
        for k, dt in enumerate(dts, start=1):
            phi, chol = _matern32_step(dt, lam, amplitude)
            x = x @ phi.T + rng.standard_normal((m, 2)) @ chol.T
            out[:, k] = x[:, 0]
    else:
        raise ValueError(f"unknown kernel {kernel!r} (exp or matern32)")
    return out[0] if size is None else out


def _columns(cfg: Config, truth: TruthConfig, p: Protocol, stress: np.ndarray,
             rng: np.random.Generator, measured: np.ndarray | None = None
             ) -> list[tuple[str, str, np.ndarray]]:
    """(role, header, values in the package's units), in the order time, axial strain, eps22,
    force, stress. ``measured``: the strain the axial channel reports, when it differs from the
    specimen's (``truth.model_form``)."""
    noise, c, d = truth.noise, cfg.data.columns, cfg.data
    n = p.time.size
    axial = p.strain if measured is None else measured
    eps11 = axial + rng.normal(0.0, noise.strain_sd, n) if noise.strain_sd > 0 else axial.copy()
    observed = stress + rng.normal(0.0, noise.stress_sd, n) if noise.stress_sd > 0 else stress.copy()
    force_noise = rng.normal(0.0, noise.force_sd, n) if noise.force_sd > 0 else np.zeros(n)
    eps22 = -0.5 * p.strain
    if c.eps22 is not None and noise.strain_sd > 0:
        eps22 = eps22 + rng.normal(0.0, noise.strain_sd, n)
    if noise.correlated is not None and noise.correlated.amplitude > 0:
        k = noise.correlated
        observed = observed + correlated_error(p.time, k.kernel, k.amplitude, k.length, rng)
    out: list[tuple[str, str, np.ndarray]] = []
    as_written = nominal_from_hencky if d.strain_measure == "nominal" else np.asarray
    if c.time is not None:
        out.append(("time", c.time, p.time))
    if c.extension is not None:
        out.append(("extension", c.extension, nominal_from_hencky(eps11) * d.gauge_length))
    else:
        role = "eps11" if c.eps11 is not None else "strain"
        out.append((role, c.eps11 or c.strain, as_written(eps11)))
    if c.eps22 is not None:
        out.append(("eps22", c.eps22, as_written(eps22)))
    if c.force is not None:
        # σ* = F/S0·exp(ε11) (eq. 6) or σ = F/S0·exp(-2ε22) (eq. 2) gives back the observed stress
        shrink = np.exp(2.0 * eps22) if d.observable == "sigma" else np.exp(-eps11)
        out.append(("force", c.force, observed * d.area0 * shrink + force_noise))
    if c.stress is not None:
        out.append(("stress", c.stress, observed))
    return out


def _temperature_column(cfg: Config, truth: TruthConfig, time: np.ndarray
                        ) -> list[tuple[str, str, np.ndarray]]:
    """The temperature column that ``data.temperature`` names (°C, or K by its unit), when the
    truth has a temperature."""
    col = cfg.data.temperature_column
    if col is None or truth.temperature is None:
        return []
    t = np.broadcast_to(truth.temperature_at(time), time.shape).astype(float)
    return [("temperature", str(col.column), t + 273.15 if col.unit == "K" else t)]


def _temperature_notes(cfg: Config, truth: TruthConfig) -> list[str]:
    """What the fit will not know of the truth's temperature."""
    d = cfg.data
    if truth.temperature is None:
        return ["data.temperature names a column, but the truth has no temperature: not written"] if (
            d.temperature_column is not None) else []
    if not d.has_temperature:
        return ["the truth has a temperature, but data.temperature is not set: the fit will not "
                "know it"]
    if d.temperature_column is None and truth.temperature_at(np.zeros(1)) != d.temperature:
        return [f"data.temperature ({d.temperature:g} °C) is not the truth's"]
    return []


def _unit(cfg: Config, layout: str, role: str) -> str | None:
    """The unit a column is written in: data.units, data.strain_unit, else the layout's."""
    d = cfg.data
    if role in d.units:
        return d.units[role]
    if role in ("eps11", "eps22", "strain") and d.strain_unit is not None:
        return "%" if d.strain_unit == "percent" else "fraction"
    spec = LAYOUTS[layout]["units"]
    return None if spec is None else spec[_KIND[role]]


def _number(v: float, decimal: str, thousands: str | None) -> str:
    text = FORMAT % v
    if thousands and "e" not in text and abs(v) >= 1000:
        whole, _, frac = text.partition(".")
        sign = "-" if whole.startswith("-") else ""
        whole = whole.lstrip("-")
        groups = []
        while len(whole) > 3:
            groups.insert(0, whole[-3:])
            whole = whole[:-3]
        text = sign + thousands.join([whole, *groups]) + ("." + frac if frac else "")
    return text.replace(".", decimal) if decimal != "." else text


def _metadata(cfg: Config, layout: str) -> list[list[str]]:
    """A deterministic metadata block, as machine software writes one above the data."""
    truth = cfg.truth
    area = cfg.data.area0
    if layout == "bluehill":
        rows = [["Sample", cfg.name], ["Method", "bayes_dnlr simulate (synthetic test)"],
                ["Specimen label", "1"]]
        if area:
            rows.append(["Area", _number(area, ".", ","), "mm^2"])
        rows.append(["Rate", _number(truth.strain_rate, ".", ","), "1/s (true strain rate)"])
        return rows
    rows = [["Prüfvorschrift", "bayes_dnlr simulate (synthetischer Versuch)"], ["Probe", cfg.name]]
    if area:
        rows.append(["Querschnitt", _number(area, ",", None), "mm²"])
    return rows


def _csv_bytes(cfg: Config, columns: list[tuple[str, str, np.ndarray]], layout: str) -> bytes:
    spec = LAYOUTS[layout]
    delimiter = cfg.data.delimiter or spec["delimiter"]
    buf = io.StringIO()
    quoting = csv.QUOTE_ALL if spec["quote"] else csv.QUOTE_MINIMAL
    w = csv.writer(buf, delimiter=delimiter, lineterminator="\n", quoting=quoting)
    scaled = []
    units = []
    for role, _, values in columns:
        if role == "temperature":      # written in its own unit (_temperature_column)
            col = cfg.data.temperature_column
            scaled.append(values)
            units.append(None if layout == "plain" else (col.unit or "°C"))
            continue
        unit = _unit(cfg, layout, role)
        f = 1.0 if unit is None else factor(role, unit)
        scaled.append(values / f)
        units.append(unit)
    if layout != "plain":
        w.writerows(_metadata(cfg, layout))
        buf.write("\n")
    w.writerow([h for _, h, _ in columns])
    if layout != "plain":
        w.writerow([spec["unit_text"].format(u if u != "fraction" else "-") for u in units])
    rows = np.column_stack(scaled)
    w.writerows([[_number(v, spec["decimal"], spec["thousands"]) for v in row] for row in rows])
    return buf.getvalue().encode()


def _numbers(data: bytes, layout: str, delimiter: str) -> tuple[list[str], np.ndarray] | None:
    """(the text lines before the data, the data as an array), or None when it does not parse."""
    spec = LAYOUTS[layout]
    try:
        lines = data.decode().splitlines()
    except UnicodeDecodeError:
        return None
    if layout == "plain":
        skip = 1
    elif "" in lines:
        skip = lines.index("") + 3          # metadata, the blank line, header and units rows
    else:
        return None
    rows = list(csv.reader(lines[skip:], delimiter=delimiter))
    values = [[parse_cell(c, spec["decimal"]) for c in r] for r in rows]
    if any(v is None for r in values for v in r):
        return None
    try:
        return lines[:skip], np.array(values, dtype=float)
    except ValueError:
        return None


def _same_numbers(old: bytes, new: bytes, layout: str = "plain", delimiter: str = ",") -> bool:
    """Same text around the data and the same numbers up to the last printed digit (another CPU's
    rounding)."""
    a, b = _numbers(old, layout, delimiter), _numbers(new, layout, delimiter)
    if a is None or b is None or a[0] != b[0]:
        return False
    x, y = a[1], b[1]
    return x.shape == y.shape and bool(np.allclose(x, y, rtol=1e-8, atol=1e-12))


def write_unless_same(path: Path, data: bytes, overwrite: bool, source: object, layout: str = "plain",
           delimiter: str = ",") -> tuple[str, list[str]]:
    """Write unless identical; never replace a different file without ``overwrite``."""
    if path.is_file():
        old = path.read_bytes()
        if old == data:
            return "up to date", []
        if not overwrite:
            if _same_numbers(old, data, layout, delimiter):
                return "up to date", ["the file differs from this machine's output only in the last "
                                      "printed digit (floating-point rounding); kept"]
            raise DataError(f"{path}: exists and differs from what simulate makes from {source} "
                            f"(truth: section); not overwritten. Use --force to "
                            f"replace it, or point data.file elsewhere")
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)
    return "written", []


def simulate_test(cfg: Config, overwrite: bool = False) -> SimulationResult:
    """Write the synthetic test of ``cfg.truth`` to ``cfg.data_path`` (see the module docstring)."""
    from bayes_dnlr.model import simulate

    truth = _check(cfg)
    rng = np.random.default_rng(truth.seed)
    kind = None if truth.model_form is None else truth.model_form.kind
    strength = "mild" if truth.model_form is None else truth.model_form.strength

    shift = Shift(truth.shift.temperature, truth.shift.reference_temperature, truth.shift.stress,
                  truth.shift.driving)

    def made(time: np.ndarray, strain: np.ndarray, relaxation_start: float | None):
        if kind is None:
            return simulate(time, strain, truth.params, modes=cfg.model.modes,
                            decades=cfg.model.decades, relaxation_start=relaxation_start,
                            shift=shift, temperature=truth.temperature_at(time)), None
        form = generate(time, strain, truth.params, relaxation_start, kind, strength,
                        cfg.model.modes, cfg.model.decades)
        return form.stress, form.measured_strain

    if truth.cycles is None:
        p = protocol(truth, rng)
    else:
        p = cyclic_protocol(truth, rng, lambda t, e: made(t, e, None)[0])
    stress, measured = made(p.time, p.strain, p.relaxation_start)
    columns = _columns(cfg, truth, p, stress, rng, measured)
    columns += _temperature_column(cfg, truth, p.time)
    source = cfg.source if cfg.source is not None else "the config"
    data = _csv_bytes(cfg, columns, truth.layout)
    delimiter = cfg.data.delimiter or LAYOUTS[truth.layout]["delimiter"]
    status, notes = write_unless_same(cfg.data_path, data, overwrite, source, truth.layout, delimiter)
    notes += _temperature_notes(cfg, truth)
    rs = cfg.data.relaxation_start
    if isinstance(rs, float) and p.relaxation_start is not None and not np.isclose(rs, p.relaxation_start):
        notes.append(f"data.relaxation_start is {rs:g} s but the hold starts at {p.relaxation_start:g} s")
    if p.relaxation_start is not None and rs is None:
        notes.append("the test has a hold but data.relaxation_start is null: the fit will treat it as "
                     "tensile")
    return SimulationResult(cfg.data_path, status, cfg.name, truth, p.time, p.strain, stress,
                            p.relaxation_start, tuple(notes))


def simulate_tests(cfg: Config, overwrite: bool = False) -> list[SimulationResult]:
    """Every test's synthetic file: ``[simulate_test(cfg)]`` for one test; for a run with
    ``tests:``, each test from its own ``tests[i].truth`` (all are checked before any is written)."""
    views = cfg.test_configs()
    where = cfg.source if cfg.source is not None else "config"
    for i, v in enumerate(views):
        if v.truth is None and cfg.tests is not None:
            raise ConfigError(f"{where}: tests[{i}].truth: section is missing: simulate needs each "
                              "test's known parameters and protocol (see docs/joint.md)")
        _check(v)            # every test checked before any file is written
    return [simulate_test(v, overwrite) for v in views]
