"""Damage as a disk, a cut copy or another program does it, for the adversary tests
(tests/adversary/) and benchmarks/damaged_chains.py: bytes flipped at a stride from an offset, a
file cut, a range of metadata zeroed."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

Damage = Callable[[bytes], bytes]


def flipped(stride: int, offset: int) -> Damage:
    """Every ``stride``-th byte from ``offset`` inverted."""
    def damage(data: bytes) -> bytes:
        b = bytearray(data)
        for i in range(offset, len(b), stride):
            b[i] ^= 0xFF
        return bytes(b)
    return damage


def cut(fraction: float) -> Damage:
    return lambda data: data[: int(len(data) * fraction)]


def zeroed(start: int, stop: int) -> Damage:
    """Bytes ``start:stop`` set to zero (negative: from the end)."""
    def damage(data: bytes) -> bytes:
        b = bytearray(data)
        a, z = (start % len(b), stop % len(b) or len(b)) if start < 0 else (start, min(stop, len(b)))
        b[a:z] = bytes(z - a)
        return bytes(b)
    return damage


def heap_zeroed(data: bytes) -> bytes:
    """The start of HDF5's global heap (where h5py keeps string attributes; no checksum) zeroed:
    HDF5 then loops at full CPU reading the attributes."""
    at = data.find(b"GCOL")
    assert at >= 0, "no global heap in this file"
    return zeroed(at + 16, at + 32)(data)


# 10 strides and offsets, the cuts, metadata zeroed (the cases, and more)
STRIDES = [(997, 2048), (1009, 0), (4096, 512), (577, 100), (251, 4000), (8191, 48), (1499, 1024),
           (10007, 3000), (3001, 700), (127, 16)]
CHAIN_DAMAGES: dict[str, Damage] = {
    **{f"flip{s}@{o}": flipped(s, o) for s, o in STRIDES},
    **{f"cut{f:g}": cut(f) for f in (0.0, 0.1, 0.5, 0.9, 0.99)},
    "zero-superblock": zeroed(0, 512),
    "zero-metadata": zeroed(48, 4096),
    "zero-tail": zeroed(-4096, 0),
    "zero-global-heap": heap_zeroed,
}


def damage_file(path: Path, damage: Damage) -> None:
    path.write_bytes(damage(path.read_bytes()))
