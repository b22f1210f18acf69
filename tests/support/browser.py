"""Headless Chromium for the tests that look at the pages as a reader does (docs/screenshot.py
drives it): whether it is here, and the mark of those tests.

Chromium is not a dependency of the package (Debian: ``apt-get install chromium``). The tests that
need it carry ``browser``: the ``browser`` mark (counted on pytest's last line by conftest.py, as
the real-data tests are) and a skip when no Chromium is installed.
"""

from __future__ import annotations

import importlib.util
import struct
import sys
from pathlib import Path

import pytest

_SPEC = importlib.util.spec_from_file_location(
    "docs_screenshot", Path(__file__).resolve().parents[2] / "docs" / "screenshot.py")
screenshot = sys.modules.setdefault("docs_screenshot", importlib.util.module_from_spec(_SPEC))
if not hasattr(screenshot, "open_page"):
    _SPEC.loader.exec_module(screenshot)

EXE = screenshot.find_chromium()
PRESENT = EXE is not None
REASON = "no Chromium installed (apt-get install chromium)"
MARKS = (pytest.mark.browser, pytest.mark.skipif(not PRESENT, reason=REASON))


def browser(test):
    """Decorate a test that opens a page in Chromium."""
    for mark in MARKS:
        test = mark(test)
    return test


def png_size(path: Path) -> tuple[int, int]:
    """(width, height) of a PNG, from its header."""
    head = path.read_bytes()[:24]
    assert head[:8] == b"\x89PNG\r\n\x1a\n", path
    return struct.unpack(">II", head[16:24])
