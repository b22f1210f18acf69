"""Reading a DMA frequency sweep (data/dma.py) from the exports of the usual instruments: what
simulate writes in each layout comes back to the printed digits, tan δ and angular frequency are
converted, and a file the sweep cannot be read from says why."""

from __future__ import annotations

import numpy as np
import pytest

from bayes_dnlr.data import DataError
from bayes_dnlr.data.dma import looks_like_sweep, read_sweep
from bayes_dnlr.model.modulus import complex_modulus
from bayes_dnlr.workflows.sweeps import sweep_bytes

F = np.geomspace(0.1, 100, 16)
STORAGE, LOSS = complex_modulus(F, 2854.0, 2.32, 5.79)


@pytest.mark.parametrize("layout", ["plain", "trios", "netzsch", "anton-paar"])
@pytest.mark.parametrize("temperature", [None, 23.0])
def test_every_layout_reads_back(tmp_path, layout, temperature):
    path = tmp_path / f"{layout}.txt"
    path.write_bytes(sweep_bytes(F, STORAGE, LOSS, temperature, layout))
    sweep = read_sweep(path)
    np.testing.assert_allclose(sweep.frequency, F, rtol=1e-7)
    np.testing.assert_allclose(sweep.storage, STORAGE, rtol=1e-7)      # Pa -> MPa for Anton Paar
    np.testing.assert_allclose(sweep.loss, LOSS, rtol=1e-7)
    if temperature is None:
        assert sweep.temperature is None
    else:
        np.testing.assert_allclose(sweep.temperature, temperature)
    assert looks_like_sweep(path)


def test_tan_delta_angular_frequency_and_kelvin(tmp_path):
    w = 2 * np.pi * F
    rows = ["Angular frequency (rad/s),E' (GPa),tan delta,Temperature (K)"]
    rows += [f"{a:.10g},{s / 1e3:.10g},{loss / s:.10g},296.15" for a, s, loss in zip(w, STORAGE, LOSS,
                                                                                       strict=True)]
    path = tmp_path / "sweep.csv"
    path.write_text("\n".join(rows) + "\n")
    sweep = read_sweep(path)
    np.testing.assert_allclose(sweep.frequency, F, rtol=1e-9)
    np.testing.assert_allclose(sweep.storage, STORAGE, rtol=1e-9)
    np.testing.assert_allclose(sweep.loss, LOSS, rtol=1e-9)
    np.testing.assert_allclose(sweep.temperature, 23.0)
    assert any("tan δ" in n for n in sweep.notes)


def test_columns_and_units_from_the_config(tmp_path):
    path = tmp_path / "odd.csv"
    path.write_text("a,b,c\n" + "\n".join(f"{f:.10g},{s * 1e6:.10g},{loss * 1e6:.10g}"
                                          for f, s, loss in zip(F, STORAGE, LOSS, strict=True)))
    with pytest.raises(DataError, match="no frequency column"):
        read_sweep(path)
    sweep = read_sweep(path, {"frequency": "a", "storage": 2, "loss": "c"}, {"storage": "Pa", "loss": "Pa"})
    np.testing.assert_allclose(sweep.storage, STORAGE, rtol=1e-9)


@pytest.mark.parametrize("text, words", [
    ("Frequency (Hz),Storage modulus,Loss modulus\n1,2,3\n2,3,4\n", "has no unit in the file"),
    ("Frequency (Hz),Storage modulus (s),Loss modulus (MPa)\n1,2,3\n2,3,4\n", "not a stress unit"),
    ("Frequency (Hz),G' (Pa),G'' (Pa)\n1,2,3\n2,3,4\n", "shear modulus"),
    ("Frequency (Hz),Storage modulus (MPa),Loss modulus (MPa)\n1,2,3\n2,3,-4\n", "negative loss"),
    ("Frequency (Hz),Storage modulus (MPa),Loss modulus (MPa)\n1,2,3\n0,3,4\n", "must be positive"),
    ("Frequency (Hz),Storage modulus (MPa),Loss modulus (MPa)\n1,2,3\n", "at least 2"),
    ("Time (s),Force (N),Strain\n0,0,0\n1,2,0.1\n2,4,0.2\n3,5,0.3\n4,6,0.4\n", "no frequency column"),
])
def test_a_file_that_is_no_sweep_says_why(tmp_path, text, words):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(DataError, match=words) as err:
        read_sweep(path)
    assert str(path) in str(err.value)
