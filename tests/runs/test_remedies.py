"""The verdict's remedies, followed as a user would: on real-like synthetic tests (a small-strain
ramp, a ramp then a hold, loading-unloading cycles, each from a richer model than the fitted
one), every config edit the verdict names is made and the test sampled again. E(t) must not leave
its previous interval unless one of the two verdicts says why (its trust withdrawn)."""

from __future__ import annotations

import re

import pytest
import yaml
from support.runs import make_run

from bayes_dnlr.config import ALPHA_PRIOR, load_config
from bayes_dnlr.runs.sample import sample

pytestmark = pytest.mark.slow

SAMPLER = {"walkers": 32, "max_steps": 3000, "target_ess": 400, "checkpoint_every": 100}
CASES = {
    "small-strain": {"params": {"E": 1500.0, "G": 5.0, "tau_max": 2000.0}, "strain_rate": 1e-3,
                     "strain_max": 0.02, "n_points": 200, "model_form": {"kind": "spectrum-power"},
                     "noise": {"strain_sd": 0.0, "stress_sd": 0.02}, "seed": 3},
    "ramp-hold": {"params": {"E": 1200.0, "G": 30.0, "tau_max": 8.0, "sigma_inf": 6.0, "tau_max_R": 50.0},
                  "strain_rate": 1e-3, "strain_max": 0.01, "hold": 300.0, "sample_rate": 5,
                  "model_form": {"kind": "two-process"}, "noise": {"strain_sd": 0.0, "stress_sd": 0.02},
                  "seed": 11},
    "cycles": {"params": {"E": 2000.0, "G": 5.0, "tau_max": 60.0}, "strain_rate": 1e-3,
               "strain_max": 0.02, "cycles": {"count": 3}, "sample_rate": 5,
               "model_form": {"kind": "spectrum-lognormal"}, "noise": {"strain_sd": 0.0, "stress_sd": 0.02},
               "seed": 5},
}


def remedies(summary: dict) -> list[tuple[str, object]]:
    """The config edits the verdict and E(t)'s trust name: (dotted key, value)."""
    checks = summary["checks"]
    text = " ".join([checks["verdict"], *(r for row in summary["modulus_at"] for r in row["trust_reasons"])])
    out: list[tuple[str, object]] = []
    for name in re.findall(r"Widen parameters\.(\w+) and run again", text):
        entry = next(b for b in checks["bound_limited"] if b["parameter"] == name)
        lo, hi = entry["widened"]
        out.append((f"parameters.{name}.low", lo))
        out.append((f"parameters.{name}.high", hi))
    for t in re.findall(r"data\.window: \{time_max: ([0-9.eE+-]+)\}", text):
        out.append(("data.window", {"time_max": float(t)}))
    if "Sample the exponent (parameters.alpha" in text:
        out.append(("parameters.alpha", dict(ALPHA_PRIOR)))
    return out


def apply(raw: dict, key: str, value: object) -> None:
    keys = key.split(".")
    d = raw
    for k in keys[:-1]:
        d = d.setdefault(k, {})
    d[keys[-1]] = value


@pytest.mark.parametrize("case", list(CASES))
def test_following_a_remedy_moves_e_t_only_with_a_reason(tmp_path, case):
    truth = CASES[case]
    data = {"relaxation_start": "auto"} if truth.get("hold") else {}
    path = make_run(tmp_path, case, truth, sigma0=0.02, data=data, sampler=SAMPLER)
    first = sample(load_config(path), progress=False).summary
    edits = remedies(first)
    for key, value in edits:
        raw = yaml.safe_load(path.read_text())
        raw.pop("truth")            # the data stay as they are
        if key.startswith("parameters.") and key.count(".") == 2:
            name = key.split(".")[1]
            from bayes_dnlr.config import DEFAULT_PRIORS

            raw.setdefault("parameters", {}).setdefault(name, dict(DEFAULT_PRIORS[name]))
        apply(raw, key, value)
        raw["name"] = f"{case}-{key.replace('.', '-')}"
        folder = tmp_path / raw["name"]
        folder.mkdir()
        raw["data"]["file"] = str(path.parent / raw["data"]["file"])
        (folder / "config.yaml").write_text(yaml.safe_dump(raw))
        again = sample(load_config(folder / "config.yaml"), progress=False).summary
        for before, after in zip(first["modulus_at"], again["modulus_at"], strict=False):
            if before["t"] != after["t"]:
                continue
            lo, hi = before["hdi_90"]
            moved = not lo <= after["mean"] <= hi
            said = not before["trust"] or not after["trust"]
            assert not moved or said, (case, key, before, after)
