"""The test the model sees: ``load_test(cfg)`` reads, converts, smooths and windows one test.

``load_test(cfg)`` reads the export that ``cfg.data`` describes and returns a ``TestData``: every
data row of the file, in file order (trailing padding, rows outside ``data.rows`` and a compensated
toe left out with a note), with the observable stress (σ* eq. 6, σ eq. 2 or a true-stress column),
the measured Hencky strain (eq. 1) and the strain that drives the model (a GCV smoothing spline of
the measured strain, fitted per segment, or the raw strain). Every error is a ``DataError`` whose
message names the file, the line and the column.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bayes_dnlr.config import Config
from bayes_dnlr.data import hints, reduction
from bayes_dnlr.data.checks import (
    check_increasing,
    check_load,
    first_sample_warning,
    implausible_strain,
    percent_warning,
    spike_warning,
    to_hencky,
)
from bayes_dnlr.data.conversions import (
    nominal_from_hencky,
    nominal_from_true_stress,
    nominal_stress,
    sigma_star,
    true_stress,
)
from bayes_dnlr.data.cycles import Turns, turning_points
from bayes_dnlr.data.errors import DataError
from bayes_dnlr.data.initial_state import plan_start
from bayes_dnlr.data.ramp import detect_relaxation_start, window_strain_rate
from bayes_dnlr.data.reading import Table, read_table
from bayes_dnlr.data.repeats import merge_repeats
from bayes_dnlr.data.smoothing import (
    UnkeptSmoothing,
    sampling_breaks,
    segment_edges,
    smooth_strain,
    unkept_smoothing,
)
from bayes_dnlr.data.windows import window_mask


@dataclass(frozen=True)
class TestData:
    """One tensile (then relaxation) test, ready for the model.

    The arrays hold the data rows read, in file order (see ``notes`` for any left out), after
    ``virtual_start`` model-only samples (an unloaded start, see data/initial_state.py). The model runs from
    the first sample (history matters) to ``model_end``; the comparison with data uses the samples
    where ``window`` is True.
    """

    __test__ = False  # not a pytest test class despite its name

    path: Path
    sha256: str
    time: np.ndarray              # s
    strain: np.ndarray            # measured axial Hencky strain ε11 (eq. 1)
    strain_input: np.ndarray      # the strain that drives the model (smoothed or measured)
    stress: np.ndarray            # the observable, MPa: σ* (eq. 6), σ (eq. 2) or a stress column
    nominal_strain: np.ndarray    # e = exp(ε) - 1
    nominal_stress: np.ndarray | None  # F/S0, MPa (None when it cannot be derived)
    window: np.ndarray            # bool, the identification interval
    relaxation_start: float | None  # s (resolved: 'auto' -> the detected time)
    strain_rate: float            # mean Hencky strain rate of the loading ramp, 1/s
    observable: str               # sigma_star | sigma | stress
    notes: tuple[str, ...] = ()   # what was derived or detected (e.g. the auto relaxation start)
    force: np.ndarray | None = None              # N, when the file has a force column
    transverse_strain: np.ndarray | None = None  # measured ε22 (Hencky), when the file has one
    area0: float | None = None                   # S0, mm²
    virtual_start: int = 0        # leading model-only samples (an unloaded start), never in the window
    lines: np.ndarray | None = None  # the file line of each sample (0 for a model-only sample)
    rows_per_point: int = 1       # data.reduce: each sample the mean of this many consecutive rows
    temperature: float | np.ndarray | None = None   # °C: data.temperature, one value or one per sample
    # the smoothed strain to keep in the run folder's cache once the folder exists (``keep_smoothing``)
    unkept_smoothing: UnkeptSmoothing | None = field(default=None, repr=False, compare=False)
    # where the test unloads and reloads (data/cycles.py), indices of these arrays; computed once
    # from the measured strain and the stress when not given
    turns: Turns | None = field(default=None, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.turns is None:
            object.__setattr__(self, "turns", turns_of(self.strain, self.stress, self.virtual_start))

    def keep_smoothing(self) -> None:
        """Keep the smoothed strain in the run folder's cache, if it could not be kept when the test
        was loaded (no run folder yet): the commands after this one then read it."""
        if self.unkept_smoothing is not None:
            self.unkept_smoothing.keep()

    @property
    def model_end(self) -> int:
        """One past the last sample the model must reach (the last window sample)."""
        return int(np.flatnonzero(self.window)[-1]) + 1

    @property
    def first_peak(self) -> int | None:
        """The index of the first peak the window runs past (data/cycles.py): where the first
        loading of a cyclic window ends; None for a window without unloading."""
        return self.turns.first_peak_within(np.flatnonzero(self.window))

    @property
    def n_points(self) -> int:
        """Number of samples compared with the model (q in the paper)."""
        return int(self.window.sum())


def turns_of(strain: np.ndarray, stress: np.ndarray, first: int = 0) -> Turns:
    """The turning points of a test (data/cycles.py) on its samples from ``first`` on (after the
    model-only ones), as indices of the whole arrays."""
    return turning_points(strain[first:], stress[first:]).shifted(first)


def _observable(cfg: Config, values: dict[str, np.ndarray], strain: np.ndarray,
                eps22: np.ndarray | None, path: Path) -> np.ndarray:
    d = cfg.data
    area0 = d.area0
    if d.observable == "stress":
        if d.stress_measure == "engineering":      # isovolumic, as σ* of a force (eq. 4-6)
            return values["stress"] * np.exp(strain)
        return values["stress"]
    if area0 is None or not area0 > 0:
        raise DataError(f"{path}: data.area0 must be a positive cross-section in mm² to turn the "
                        f"force into a stress, got {area0}")
    if d.observable == "sigma":
        return true_stress(values["force"], area0, eps22)
    return sigma_star(values["force"], area0, strain)


def _nominal_stress(cfg: Config, values: dict[str, np.ndarray], strain: np.ndarray) -> np.ndarray | None:
    if "force" in values and cfg.data.area0:
        return nominal_stress(values["force"], cfg.data.area0)
    if "stress" in values and cfg.data.stress_measure == "engineering":
        return values["stress"]
    if "stress" in values:
        return nominal_from_true_stress(values["stress"], strain)
    return None


def _axial(cfg: Config, table: Table) -> tuple[np.ndarray, np.ndarray, str, list[str]]:
    """Measured axial Hencky strain (eq. 1), the nominal strain, the role it came from, notes."""
    d = cfg.data
    if "extension" in table.values:
        nominal = table.values["extension"] / d.gauge_length
        strain = to_hencky(table, nominal, "extension", "nominal")
        notes = [f"strain: extension / gauge_length ({d.gauge_length:g} mm), nominal -> Hencky, "
                 f"ε = ln(1 + e) (eq. 1)"]
        role = "extension"
    else:
        role = "eps11" if "eps11" in table.values else "strain"
        raw = table.values[role]
        strain = to_hencky(table, raw, role, d.strain_measure)
        nominal = raw if d.strain_measure == "nominal" else nominal_from_hencky(strain)
        notes = ["strain: nominal -> Hencky, ε = ln(1 + e) (eq. 1)"] if d.strain_measure == "nominal" else []
        unit_known = d.strain_unit is not None or role in d.units or bool(
            table.layout and table.layout.units[table.columns[role]])
        implausible_strain(table, role, raw, strain, d.strain_measure, unit_known)
    return strain, nominal, role, notes


def _time(cfg: Config, table: Table, strain: np.ndarray, strain_role: str) -> tuple[np.ndarray, list[str]]:
    if "time" in table.values:
        check_increasing(table, table.values["time"], "time", "time must increase strictly")
        return table.values["time"], []
    rate = cfg.data.strain_rate
    check_increasing(table, strain, strain_role,
                     f"no time column, so time = strain / data.strain_rate ({rate:g} 1/s) needs a "
                     f"strictly increasing strain")
    return strain / rate, [f"time: from strain / strain_rate ({rate:g} 1/s), no time column"]


def _relaxation_start(cfg: Config, time: np.ndarray, strain: np.ndarray, path: Path
                      ) -> tuple[float | None, list[str]]:
    rs = cfg.data.relaxation_start
    if rs is None:
        return None, []
    if rs == "auto":
        try:
            i = detect_relaxation_start(time, strain)
        except ValueError as err:
            raise DataError(f"{path}: data.relaxation_start: auto: {err}; set the time of the hold "
                            f"start (s) or null for a tensile test") from None
        return float(time[i]), [f"relaxation_start: auto -> {time[i]:g} s (detected)"]
    if not time[0] < rs < time[-1]:
        raise DataError(f"{path}: data.relaxation_start {rs:g} s lies outside the test "
                        f"(time spans {time[0]:g} to {time[-1]:g} s)")
    return float(rs), []


def _smoothing_note(time: np.ndarray, breaks: list[int], lams: list[float], sampling: list[int]) -> str:
    """λ per segment (in units of the segment's median time step, cubed)."""
    edges = segment_edges(time.size, breaks)
    parts = []
    for a, b, lam in zip(edges[:-1], edges[1:], lams, strict=True):
        text = "raw (< 5 samples)" if math.isnan(lam) else (
            "a straight line (GCV)" if math.isinf(lam) else f"λ = {lam:.4g}")
        parts.append(f"{time[a]:g}-{time[b]:g} s: {text}")
    extra = (f"; split where the sampling interval changes, at t = "
             f"{', '.join(f'{time[i]:g}' for i in sampling)} s" if sampling else "")
    return ("strain_input: smoothed (GCV smoothing spline per segment" + extra + "; " + "; ".join(parts)
            + ")")


def _check_file(cfg: Config) -> Path:
    path = cfg.data_path
    d = cfg.data
    if path.is_dir():
        raise DataError(f"{path}: is a directory, not a data file (config key data.file: {d.file!r}, "
                        f"resolved against {cfg.base_dir})")
    if not path.exists():
        raise DataError(f"{path}: data file not found (config key data.file: {d.file!r}, resolved "
                        f"against {cfg.base_dir})")
    return path


def _prepend(x: np.ndarray | None, value: float, count: int) -> np.ndarray | None:
    if x is None or count == 0:
        return x
    return np.concatenate((np.full(count, value), x))


def _load_source(d) -> str:
    """The column the load comes from, for an error message."""
    if d.observable == "stress" or d.columns.force is None:
        return f"the stress column ({d.columns.stress!r})"
    return f"the force column ({d.columns.force!r})"


def load_test(cfg: Config, cache: Path | None = None) -> TestData:
    """Read the test that ``cfg.data`` describes (see docs/data-input.md); ``cache``: a folder where
    the smoothed strain is kept by the digest of its inputs (the run folder's, from ``runs``)."""
    from bayes_dnlr.digests import file_sha256

    d = cfg.data
    path = _check_file(cfg)
    table = read_table(path, d)
    table, repeats = merge_repeats(table, d.repeated_time)
    notes = [*table.notes, *repeats]
    strain, nominal, strain_role, more = _axial(cfg, table)
    raw_nominal = nominal
    notes += more
    eps22 = None
    if "eps22" in table.values:
        eps22 = to_hencky(table, table.values["eps22"], "eps22", d.strain_measure)
    time, more = _time(cfg, table, strain, strain_role)
    notes += more
    values = dict(table.values)
    temperature = values.pop("temperature", None)
    lines = np.asarray(table.lines)

    # the state before the first sample (toe compensation, an unloaded start)
    nom_stress = _nominal_stress(cfg, values, strain)
    start = plan_start(time, strain, nominal, nom_stress, d.toe, d.initial_state, lines)
    notes += start.notes
    if start.cut or start.shift:
        k = start.cut
        time, strain, lines = time[k:], strain[k:] - start.shift, lines[k:]
        values = {r: v[k:] for r, v in values.items()}
        temperature = None if temperature is None else temperature[k:]
        eps22 = None if eps22 is None else eps22[k:]
        nominal = np.expm1(strain)
    virtual = 0
    if start.origin_time is not None:
        virtual = 1
        time = np.concatenate(([start.origin_time], time))
        strain = np.concatenate(([0.0], strain))
        nominal = np.concatenate(([0.0], nominal))
        lines = np.concatenate(([0], lines))
        values = {r: _prepend(v, 0.0, 1) for r, v in values.items()}
        temperature = None if temperature is None else _prepend(temperature, temperature[0], 1)
        eps22 = _prepend(eps22, 0.0, 1)
    if "time" in values and virtual:
        values["time"] = time

    rs, more = _relaxation_start(cfg, time, strain, path)
    notes += more
    unkept = None
    if d.strain_input == "smoothed":
        breaks = [] if rs is None else [int(np.searchsorted(time, rs))]
        sampling = sampling_breaks(time, breaks)
        segments = sorted({*breaks, *sampling})
        strain_input, lams = smooth_strain(time, strain, segments, cache)
        unkept = unkept_smoothing(cache, time, strain, segments, (strain_input, lams))
        notes.append(_smoothing_note(time, segments, lams, sampling))
    else:
        strain_input = strain
    stress = _observable(cfg, values, strain, eps22, path)
    if d.observable == "stress" and d.stress_measure == "engineering":
        notes.append("stress: engineering -> true, σ = s·exp(ε) = s·(1 + e) (isovolumic, eq. 4-6; "
                     "data.stress_measure: engineering)")
    nom_stress = _nominal_stress(cfg, values, strain)
    window = window_mask(time[virtual:], strain[virtual:], d.window, path=path, key="data.window")
    used = int(np.flatnonzero(window)[-1]) + 1 if window.any() else window.size  # rows to the window's end
    k = reduction.rows_per_point(d.reduce, used, d.strain_input)
    if k > 1:       # after the smoothing: the spline of every row, averaged like the stress
        notes.append(reduction.reduction_note(time.size - virtual, used, k, d.reduce))
        breaks = [] if rs is None else [int(np.searchsorted(time, rs))]
        cuts = reduction.bins(time.size, k, 1 + virtual, breaks)
        time, strain, strain_input, stress, nominal = (reduction.bin_means(v, cuts)
                                                       for v in (time, strain, strain_input, stress, nominal))
        nom_stress = None if nom_stress is None else reduction.bin_means(nom_stress, cuts)
        eps22 = None if eps22 is None else reduction.bin_means(eps22, cuts)
        values = {r: reduction.bin_means(v, cuts) for r, v in values.items()}
        temperature = None if temperature is None else reduction.bin_means(temperature, cuts)
        lines = np.asarray(lines)[cuts[:-1]]
    window = window_mask(time[virtual:], strain[virtual:], d.window, path=path, key="data.window")
    window = np.concatenate((np.zeros(virtual, bool), window))
    turns = turns_of(strain, stress, virtual)
    rate, how = window_strain_rate(time, strain, window, rs, first=virtual,
                                   peak=turns.first_peak_within(np.flatnonzero(window)))
    notes.append(f"strain_rate: {rate:.4g} 1/s ({how})")
    if virtual == 0 and d.toe == "none" and d.initial_state is None:
        force = values.get("force") if d.observable != "stress" else None
        warn = first_sample_warning(stress, strain, int(lines[0]), force, d.area0)
        if warn:
            notes.append(warn)
    check_load(stress, window, lines, path, _load_source(d))
    notes += _hints(cfg, table, raw_nominal, time, strain, stress, values.get("force"), nom_stress,
                    window, rs, virtual, turns)
    spike = spike_warning(stress, lines, virtual, strain, window)
    if spike:
        notes.append(spike)
    if d.strain_unit is None and strain_role != "extension" and not notes_have_units(table, strain_role, d):
        warn = percent_warning(nominal[virtual:], None if nom_stress is None else nom_stress[virtual:],
                               table.names[strain_role])
        if warn:
            notes.append(warn)
    temperature, more = _temperature(cfg, temperature)
    notes += more
    test = TestData(
        path=path, sha256=file_sha256(path), time=time, strain=strain, strain_input=strain_input,
        stress=stress, nominal_strain=nominal, nominal_stress=nom_stress, window=window,
        relaxation_start=rs, strain_rate=rate, observable=d.observable, notes=tuple(notes),
        force=values.get("force"), transverse_strain=eps22, area0=d.area0, virtual_start=virtual,
        lines=lines, rows_per_point=k, unkept_smoothing=unkept, turns=turns,
        temperature=temperature)
    return test


def _temperature(cfg: Config, column: np.ndarray | None) -> tuple[float | np.ndarray | None, list[str]]:
    """The test's temperature (°C): data.temperature's value, or its column per sample; a note of
    what it is and whether the model uses it (model.shift.temperature)."""
    d = cfg.data
    if not d.has_temperature:
        return None, []
    value: float | np.ndarray = float(d.temperature) if column is None else column
    if column is None:
        what = f"temperature: {value:g} °C (data.temperature)"
    else:
        what = (f"temperature: per row, {float(np.min(column)):.4g} to {float(np.max(column)):.4g} °C "
                f"(mean {float(np.mean(column)):.4g}; data.temperature)")
    law = cfg.model.shift.temperature
    if law == "none":
        what += ("; the model has no temperature shift (model.shift.temperature: none), so its "
                 "spectrum is the one at this temperature")
    else:
        what += f"; the spectrum is shifted to {cfg.model.shift.reference_temperature:g} °C ({law})"
    return value, [what]


def _hints(cfg: Config, table: Table, nominal: np.ndarray, time: np.ndarray, strain: np.ndarray,
           stress: np.ndarray, force: np.ndarray | None,
           nom_stress: np.ndarray | None, window: np.ndarray, rs: float | None, virtual: int,
           turns: Turns) -> list[str]:
    """What init would have noticed (data/hints.py), as warning notes."""
    d = cfg.data
    load = force if force is not None and d.observable != "stress" else nom_stress
    found = [hints.hold_without_start(d, time, strain, stress, window, virtual, turns),
             hints.engineering_as_true(d, table, nominal),
             hints.area_check(d, table),
             None if load is None else hints.window_past_peak(d, time, strain, load, window, rs,
                                                              virtual, turns)]
    return [n for n in found if n]


def notes_have_units(table: Table, role: str, d) -> bool:
    """True when the strain's unit is known from the file or the config (no guessing needed)."""
    if role in d.units:
        return True
    layout = table.layout
    return bool(layout is not None and layout.units and layout.units[table.columns[role]])
