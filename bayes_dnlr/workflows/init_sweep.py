"""``init`` on a DMA export: the ``reference_moduli`` entry that reads it, to paste into the config
of a tensile test of the same material.

A DMA frequency sweep is no test the model integrates: it observes the storage and loss moduli of
the model's modes at its frequencies (docs/config.md, "reference_moduli"). ``init`` reads the file
as the run will (data/dma.py: the instrument's column names and units), and writes a YAML file with
one entry: the file, the columns and units it found, ``use: data`` and the uncertainty to set.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

from bayes_dnlr.config.yamlio import dump_yaml
from bayes_dnlr.data.dma import read_sweep
from bayes_dnlr.errors import RunError

RELATIVE_SD = 0.02        # a DMA's moduli: about 1-3 % (geometry, clamping, calibration): to be set


@dataclass
class SweepInit:
    path: Path
    entry: dict
    found: list[str] = field(default_factory=list)
    edits: list[str] = field(default_factory=list)

    def text(self) -> str:
        lines = [f"wrote {self.path} (a reference_moduli entry: a DMA sweep)", *self.found]
        lines.append("paste it under reference_moduli: in the config of a tensile test of the same "
                     f"material, and edit ({len(self.edits)}):")
        lines += [f"  {i}. {e}" for i, e in enumerate(self.edits, 1)]
        lines.append("docs: docs/config.md (reference_moduli), docs/report.md (Table 4)")
        return "\n".join(lines)


def init_sweep(data: Path, out: Path | None, name: str) -> SweepInit:
    """Write the entry for the DMA export ``data`` to ``out`` (default runs/<name>/reference.yaml);
    never overwrites."""
    sweep = read_sweep(data)
    out = Path(out) if out is not None else Path("runs") / name / "reference.yaml"
    if out.exists():
        raise RunError(f"{out}: exists; init never overwrites a file (give --out another path)")
    rel = os.path.relpath(data.resolve(), out.parent.resolve())
    entry = {"method": "dma", "name": name, "file": rel, "relative_sd": RELATIVE_SD, "use": "data"}
    f = sweep.frequency
    found = [f"read {data}: a DMA sweep of {f.size} rows, {f.min():.3g}-{f.max():.3g} Hz, E' "
             f"{sweep.storage.min():.4g}-{sweep.storage.max():.4g} MPa"
             + ("" if sweep.loss is None else f", E'' {sweep.loss.min():.4g}-{sweep.loss.max():.4g} MPa")]
    found += [f"  {n}" for n in sweep.notes]
    edits = [f"set relative_sd (now {RELATIVE_SD}): the uncertainty of each E' and E'' as a fraction "
             "(or sd in MPa); it is the width of the sweep's likelihood term",
             f"check file (now {rel}): relative to the config it goes into",
             "check use (now data): data puts the sweep in the likelihood beside the tensile test; "
             "check holds it out and compares it with the posterior's prediction"]
    if sweep.temperature is not None:
        lo, hi = float(sweep.temperature.min()), float(sweep.temperature.max())
        found.append(f"  temperature {lo:.4g} °C" if hi - lo <= 1.0 else
                     f"  temperature {lo:.4g}-{hi:.4g} °C (per row)")
        if hi - lo > 1.0:
            edits.append("the rows span several temperatures: without a shift factor (model.shift) "
                         "keep the rows of the tensile test's temperature, or use: check")
    text = ("# A DMA frequency sweep, read by `python -m bayes_dnlr init`: paste this entry under\n"
            "# reference_moduli: of a tensile test's config (docs/config.md, 'reference_moduli').\n"
            + dump_yaml({"reference_moduli": [entry]}))
    out.parent.mkdir(parents=True, exist_ok=True)
    try:
        with open(out, "x", encoding="utf-8") as fh:
            fh.write(text)
    except FileExistsError:
        raise RunError(f"{out}: exists; init never overwrites a file (give --out another path)") from None
    return SweepInit(out, entry, found, edits)
