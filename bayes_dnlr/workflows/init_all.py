"""``init FILE --all``: a config for every specimen of an export that holds several side by side,
and the batch manifest that runs them all.

    runs/<file>/<file>-1/config.yaml, <file>-2/config.yaml, ...   one per specimen (init's config)
    runs/<file>/specimens.csv                                        the manifest: name, config, ...

Each config is the one ``init`` writes for that specimen (``specimen: k``): its own window (the
peak of its own load), its own first-sample remedy, its own check lines, its test temperature
(``data.temperature``: a column of its group, or the file's metadata or name); the columns are
guessed once, from the first specimen, as the reader reads every group the same way. The material
the file states is each config's ``material:`` (workflows/init_labels.py). The manifest shows both
in columns (``material``, ``data.temperature``), the values of each row's config: a cell overrides
its config's key, as the batch reads a manifest. ``python -m bayes_dnlr batch --manifest
runs/<file>/specimens.csv`` runs each specimen where its config runs alone, so a specimen sampled by
hand is not sampled again. Nothing is overwritten: an existing config or
manifest stops it before anything is written, and a failure leaves nothing of this call behind.
"""

from __future__ import annotations

import csv
import io
import os
from dataclasses import dataclass
from pathlib import Path

from bayes_dnlr.data.guess import guess_columns
from bayes_dnlr.errors import RunError
from bayes_dnlr.workflows.init import InitResult, init_config, run_name
from bayes_dnlr.workflows.init_labels import Labels, read_labels
from bayes_dnlr.workflows.init_text import flow

MANIFEST = "specimens.csv"


@dataclass
class AllResult:
    folder: Path
    manifest: Path
    configs: list[InitResult]
    labels: Labels
    group: tuple[int, int] | None

    def text(self) -> str:
        """What was written, the first specimen's reading and edits in full, each other specimen's
        where it differs, the labels, and the command that runs them all."""
        n = len(self.configs)
        side = (f" ({n} side by side, groups of {self.group[1]} columns)" if self.group else " (one)")
        lines = [f"wrote {n} config(s), one per specimen{side}, and the batch manifest {self.manifest}"]
        first = self.configs[0]
        for line in first.text().splitlines()[1:-1]:
            if line.startswith("before `python -m bayes_dnlr fit"):
                line = (f"before the batch, edit each config ({len(first.edits)}; a specimen's own "
                        "edits are listed under it below):")
            elif line.startswith("nothing to edit"):
                line = "nothing to edit in any config but what is listed under a specimen below"
            lines.append(line)
        seen = {(e.key, str(e.value)) for e in first.edits}
        for r in self.configs[1:]:
            window = r.raw["data"].get("window")
            lines.append(f"specimen {r.raw['data'].get('specimen')}: {r.path} (window {window})")
            lines += [f"  {e.line()}" for e in r.edits if (e.key, str(e.value)) not in seen]
            lines += [f"  warning: {p}" for p in r.problems if p not in first.problems]
        m = self.labels.material
        lines.append(f"material: {m.value} (read from {m.where})" if m else
                     "material: the file does not say")
        if all("temperature" not in r.raw["data"] for r in self.configs):
            lines.append("test temperature: the file does not say (data.temperature, docs/data-input.md)")
        lines.append(f"run them all: python -m bayes_dnlr batch --manifest {self.manifest}")
        lines.append("docs: docs/data-input.md (init, --all), docs/batch.md (the manifest)")
        return "\n".join(lines)


def _manifest_text(data: Path, folder: Path, configs: list[InitResult]) -> str:
    """The manifest: a row per specimen, its config, and the labels its config holds (material,
    data.temperature) where the file states them."""
    label_keys = [k for k, get in (("material", lambda r: r.raw.get("material")),
                                   ("data.temperature", lambda r: r.raw["data"].get("temperature")))
                  if any(get(r) is not None for r in configs)]
    buf = io.StringIO()
    buf.write(f"# written by `python -m bayes_dnlr init {data} --all`: one row per specimen, its own "
              "config in the config column (relative to this file)\n")
    buf.write(f"# run them all: python -m bayes_dnlr batch --manifest {folder / MANIFEST}\n")
    if label_keys:
        buf.write(f"# {' and '.join(label_keys)}: each row's config's, as the file states it; a cell "
                  "overrides its config's key (empty: the config's)\n")
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["name", "config", *label_keys])
    for r in configs:
        cells = [r.raw.get("material"), r.raw["data"].get("temperature")]
        values = dict(zip(("material", "data.temperature"), cells, strict=True))
        w.writerow([r.path.parent.name, os.path.relpath(r.path, folder),
                    *("" if values[k] is None else flow(values[k]) if not isinstance(values[k], str)
                      else values[k] for k in label_keys)])
    return buf.getvalue()


def init_all(data: str | Path, folder: str | Path | None = None) -> AllResult:
    """Write a config per specimen of ``data`` and the manifest ``folder/specimens.csv`` (module
    doc); ``folder`` defaults to runs/<file name>."""
    data = Path(data)
    if not data.is_file():
        raise RunError(f"{data}: data file not found (init takes a test export, e.g. a CSV)")
    folder = Path(folder) if folder is not None else Path("runs") / run_name(data.stem)
    if folder.suffix in (".yaml", ".yml"):
        raise RunError(f"{folder}: with --all, --out names the folder for the configs and the manifest "
                       "(e.g. runs/etfe), not a config file")
    guess = guess_columns(data)
    n = guess.group[0] if guess.group else 1
    stem = run_name(data.stem)
    paths = [folder / (f"{stem}-{k}" if n > 1 else stem) / "config.yaml" for k in range(1, n + 1)]
    manifest = folder / MANIFEST
    there = [p for p in (*paths, manifest) if p.exists()]
    if there:
        raise RunError(f"{there[0]}: exists; init never overwrites (give --out another folder)")
    labels = read_labels(data, guess.layout)
    made = [q for q in (folder, *folder.parents) if not q.exists()]
    written: list[InitResult] = []
    try:
        for k, path in enumerate(paths, 1):
            written.append(init_config(data, path, specimen=k if n > 1 else None, guess=guess,
                                       labels=labels))
        tmp = manifest.with_name(f".{MANIFEST}.{os.getpid()}.tmp")
        tmp.write_text(_manifest_text(data, folder, written), encoding="utf-8")
        os.replace(tmp, manifest)
    except BaseException:
        for r in written:                # this call's configs and the folders it made, when empty
            r.path.unlink(missing_ok=True)
            for q in (r.path.parent, *made):
                try:
                    q.rmdir()
                except OSError:
                    pass
        raise
    return AllResult(folder, manifest, written, labels, guess.group)
