"""The text of the config ``init`` writes: YAML whose every name is escaped.

File names and header cells are the user's (or a machine's): they may hold a newline, a tab, a
quote, a '#' or a character YAML reads as a line break (U+0085, U+2028, U+2029). None of them may
change the document: a string value is written plain only when YAML reads it back as the same
string on one line, else double-quoted with escapes; a comment gets the same escapes, unquoted.
"""

from __future__ import annotations

from typing import Any

import yaml

_BREAKS = "\x85\u2028\u2029"


def _escape_char(c: str) -> str:
    o = ord(c)
    if c == "\n":
        return "\\n"
    if c == "\t":
        return "\\t"
    if o < 0x100:
        return f"\\x{o:02x}"
    return f"\\u{o:04x}" if o < 0x10000 else f"\\U{o:08x}"


def _printable(c: str) -> bool:
    return c.isprintable() and c not in _BREAKS


def comment(text: str) -> str:
    """``text`` as one line of a YAML comment: control characters and line breaks escaped."""
    return "".join(c if _printable(c) else _escape_char(c) for c in str(text))


def quoted(text: str) -> str:
    """A YAML double-quoted scalar that reads back as ``text``, on one line."""
    body = "".join('\\"' if c == '"' else "\\\\" if c == "\\" else c if _printable(c) else _escape_char(c)
                   for c in text)
    return f'"{body}"'


def scalar(text: str) -> str:
    """``text`` as a YAML scalar on one line: plain or single-quoted when YAML reads that back as the
    same string, else double-quoted with escapes."""
    if all(_printable(c) for c in text):
        dumped = yaml.safe_dump(text, default_flow_style=True, width=10**6, allow_unicode=True)
        dumped = dumped.strip().removesuffix("...").strip()
        if "\n" not in dumped and yaml.safe_load(dumped) == text:
            return dumped
    return quoted(text)


def flow(v: Any) -> str:
    """A value (mapping, list, string, number, bool, None) in YAML flow style on one line."""
    if isinstance(v, dict):
        return "{" + ", ".join(f"{scalar(str(k))}: {flow(x)}" for k, x in v.items()) + "}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(flow(x) for x in v) + "]"
    if isinstance(v, str):
        return scalar(v)
    if v is None:
        return "null"
    if isinstance(v, bool):
        return "true" if v else "false"
    return yaml.safe_dump(v, default_flow_style=True).strip().removesuffix("...").strip()


def _line(indent: str, key: str, value: Any, note: str | None, width: int = 28) -> str:
    text = f"{indent}{key}: {flow(value)}"
    return text + (" " * max(3, width - len(text)) + f"# {comment(note)}" if note else "")


def config_text(raw: dict[str, Any], comments: dict[str, str], source: str,
                column_notes: dict[str, str]) -> str:
    """The config as YAML: a comment on the keys the user may need to change, and the relation or
    the reason beside each column (``column_notes``, by role); the material the file states under
    the run's name."""
    lines = [f"# Starting config written by `python -m bayes_dnlr init {comment(source)}`.",
             "# Edit the lines marked EDIT, check the others (docs/data-input.md, docs/config.md); a",
             "# comment 'a = b ...' is a relation computed from the file's values that confirms the guess.",
             "# The priors, model and sampler are the defaults (docs/config.md).",
             f"name: {scalar(raw['name'])}                 # run name = this folder: outputs go next "
             "to this file"]
    if raw.get("material") is not None:
        note = comments.get("material")
        lines.append(f"material: {scalar(str(raw['material']))}" + (f"   # {comment(note)}" if note else ""))
    lines += ["", "data:"]
    for k, v in raw["data"].items():
        if k == "columns":
            lines.append("  columns:")
            lines += [_line("    ", role, col, column_notes.get(role)) for role, col in v.items()]
            continue
        note = comments.get(k)
        lines.append(f"  {k}: {'null' if v is None else flow(v)}" + (f"   # {comment(note)}" if note else ""))
    lines += ["", "noise:", "  sigma0: residuals                 # the noise sd from the fit's residuals "
              "(MPa); a number if you know it", ""]
    return "\n".join(lines)
