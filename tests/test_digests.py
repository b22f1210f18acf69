"""Fingerprints and plain JSON types."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from bayes_dnlr.digests import digest, file_sha256, jsonable


def test_jsonable_gives_plain_types_and_null_for_non_finite() -> None:
    obj = {"a": np.float64(1.5), "b": np.arange(3), 2: (np.int32(4), Path("x/y")), "c": math.nan,
           "d": [np.inf, -1.0], "e": np.bool_(True)}
    out = jsonable(obj)
    assert out == {"a": 1.5, "b": [0, 1, 2], "2": [4, "x/y"], "c": None, "d": [None, -1.0], "e": True}
    json.dumps(out, allow_nan=False)           # strict JSON


def test_digest_ignores_key_order_and_sees_values(tmp_path: Path) -> None:
    assert digest({"a": 1, "b": [1, 2]}) == digest({"b": [1, 2], "a": 1})
    assert digest({"a": 1}) != digest({"a": 1.0000001})
    p = tmp_path / "f.bin"
    p.write_bytes(b"abc")
    assert file_sha256(p) == "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
