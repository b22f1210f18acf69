"""The data layer's error: a bad test file, named by file, line and column."""

from __future__ import annotations

from bayes_dnlr.errors import BayesDnlrError


class DataError(BayesDnlrError, ValueError):
    """Bad test data; the message names the file, the row (line number) and the column."""
