"""The test the model sees: ``load_test(cfg)`` reads, converts, smooths and windows one test.

``load_test(cfg)`` reads the CSV that ``cfg.data`` describes and returns a ``TestData``: every row of
the file, in file order, with the observable stress (σ* eq. 6, σ eq. 2 or a true-stress column), the
measured Hencky strain (eq. 1) and the strain that drives the model (a GCV smoothing spline of the
measured strain, fitted per segment, or the raw strain). Every error is a ``DataError`` whose message
names the file, the line (header = line 1) and the column.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bayes_dnlr.config import Config
from bayes_dnlr.data.checks import _axial_strain, _check_increasing, _to_hencky
from bayes_dnlr.data.conversions import (
    nominal_from_hencky,
    nominal_from_true_stress,
    nominal_stress,
    sigma_star,
    true_stress,
)
from bayes_dnlr.data.errors import DataError
from bayes_dnlr.data.ramp import detect_relaxation_start, ramp_strain_rate
from bayes_dnlr.data.reading import _Table, read_table
from bayes_dnlr.data.smoothing import segment_edges, smooth_strain
from bayes_dnlr.data.windows import window_mask

STRAIN_ROLES = ("eps11", "eps22", "strain")


@dataclass(frozen=True)
class TestData:
    """One tensile (then relaxation) test, ready for the model.

    All arrays hold every row of the file, in file order (nothing dropped or reordered).
    The model runs from the first sample (history matters) to ``model_end``; the comparison
    with data uses the samples where ``window`` is True.
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

    @property
    def model_end(self) -> int:
        """One past the last sample the model must reach (the last window sample)."""
        return int(np.flatnonzero(self.window)[-1]) + 1

    @property
    def n_points(self) -> int:
        """Number of samples compared with the model (q in the paper)."""
        return int(self.window.sum())


def _observable(cfg: Config, table: _Table, strain: np.ndarray, eps22: np.ndarray | None) -> np.ndarray:
    d = cfg.data
    area0 = d.area0
    if d.observable == "stress":
        return table.values["stress"]
    if area0 is None or not area0 > 0:
        raise DataError(f"{table.path}: data.area0 must be a positive cross-section in mm² to turn the "
                        f"force into a stress, got {area0}")
    if d.observable == "sigma":
        return true_stress(table.values["force"], area0, eps22)
    return sigma_star(table.values["force"], area0, strain)


def _nominal_stress(cfg: Config, table: _Table, strain: np.ndarray) -> np.ndarray | None:
    if "force" in table.values and cfg.data.area0:
        return nominal_stress(table.values["force"], cfg.data.area0)
    if "stress" in table.values:
        return nominal_from_true_stress(table.values["stress"], strain)
    return None


def _time(cfg: Config, table: _Table, strain: np.ndarray, strain_role: str) -> tuple[np.ndarray, list[str]]:
    if "time" in table.values:
        _check_increasing(table, table.values["time"], "time", "time must increase strictly")
        return table.values["time"], []
    rate = cfg.data.strain_rate
    _check_increasing(table, strain, strain_role,
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


def _smoothing_note(time: np.ndarray, breaks: list[int], lams: list[float]) -> str:
    """λ per segment; 'at the bound' when GCV ran to the end of the search range (0, n)."""
    edges = segment_edges(time.size, breaks)
    parts = []
    for a, b, lam in zip(edges[:-1], edges[1:], lams, strict=True):
        n = b + 1 - a
        text = "raw (< 5 samples)" if math.isnan(lam) else f"λ = {lam:.4g}"
        if lam > 0.999 * n:
            text += " (the search bound n: the measured strain is nearly straight)"
        parts.append(f"{time[a]:g}-{time[b]:g} s: {text}")
    return "strain_input: smoothed (GCV smoothing spline per segment; " + "; ".join(parts) + ")"


def load_test(cfg: Config) -> TestData:
    """Read the test that ``cfg.data`` describes (see docs/data-input.md)."""
    from bayes_dnlr.rundir import file_sha256

    d = cfg.data
    path = cfg.data_path
    if not path.is_file():
        raise DataError(f"{path}: data file not found (config key data.file: {d.file!r}, resolved "
                        f"against {cfg.base_dir})")
    table = read_table(path, d.columns, d.delimiter, d.header)
    if d.strain_unit == "percent":
        for role in STRAIN_ROLES:
            if role in table.values:
                table.values[role] = table.values[role] / 100.0
    strain, strain_role = _axial_strain(table, d.strain_measure)
    eps22 = None
    if "eps22" in table.values:
        eps22 = _to_hencky(table, table.values["eps22"], "eps22", d.strain_measure)
    time, notes = _time(cfg, table, strain, strain_role)
    if d.strain_measure == "nominal":
        notes.append("strain: nominal -> Hencky, ε = ln(1 + e) (eq. 1)")
    rs, rs_notes = _relaxation_start(cfg, time, strain, path)
    notes += rs_notes
    if d.strain_input == "smoothed":
        breaks = [] if rs is None else [int(np.searchsorted(time, rs))]
        strain_input, lams = smooth_strain(time, strain, breaks)
        notes.append(_smoothing_note(time, breaks, lams))
    else:
        strain_input = strain
    stress = _observable(cfg, table, strain, eps22)
    window = window_mask(time, strain_input, d.window, path=path, key="data.window")
    return TestData(
        path=path, sha256=file_sha256(path), time=time, strain=strain, strain_input=strain_input,
        stress=stress,
        nominal_strain=table.values[strain_role] if d.strain_measure == "nominal" else
        nominal_from_hencky(strain),
        nominal_stress=_nominal_stress(cfg, table, strain), window=window, relaxation_start=rs,
        strain_rate=ramp_strain_rate(time, strain, rs), observable=d.observable, notes=tuple(notes),
        force=table.values.get("force"), transverse_strain=eps22, area0=d.area0)
