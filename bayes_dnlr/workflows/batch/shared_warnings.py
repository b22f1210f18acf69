"""The tests' warnings on the batch page: a warning that several tests give is listed once.

Two tests give "the same" warning when its words are the same and only its numbers differ (G held
at 0 with a sensitivity of 0.4 % of the largest in one test, 1.2 % in the other): it is one item,
each of its numbers written as the range over those tests ("0.4–1.2"), with the count of tests.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

# a number as the package writes one: not the digit of a name (tau_max_R, χ²₂, eq. 35's "35" is a
# number), a sign only where it is not a hyphen inside a word (lag-1)
NUMBER = re.compile(r"(?<![\w.])[-+−]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?|(?<=\w-)\d+(?:\.\d+)?")


@dataclass
class Shared:
    """One warning as several tests give it: its words with the numbers cut out, and each test's
    numbers in their order."""

    words: list[str]                                  # the text around the numbers
    numbers: dict[str, list[str]] = field(default_factory=dict)   # test -> its numbers as printed

    @property
    def tests(self) -> list[str]:
        return list(self.numbers)

    def text(self) -> str:
        """The warning with each number the same in every test as it is, else as its range."""
        out = [self.words[0]]
        for i, after in enumerate(self.words[1:]):
            seen = [ns[i] for ns in self.numbers.values()]
            values = sorted(set(seen), key=_value)
            out.append(values[0] if len(values) == 1 else f"{values[0]}–{values[-1]}")
            out.append(after)
        return "".join(out)


def _value(printed: str) -> float:
    return float(printed.replace("−", "-"))


def shape(warning: str) -> tuple[tuple[str, ...], list[str]]:
    """(the words around the numbers, the numbers as printed)."""
    return tuple(NUMBER.split(warning)), NUMBER.findall(warning)


def group(warnings: dict[str, list[str]]) -> list[Shared]:
    """Each distinct warning (by its words) with the tests that give it, most shared first; a test
    that gives the same words twice counts once (its first)."""
    by_words: dict[tuple[str, ...], Shared] = {}
    for test, ws in warnings.items():
        for w in ws:
            words, numbers = shape(w)
            item = by_words.setdefault(words, Shared(list(words)))
            item.numbers.setdefault(test, numbers)
    return sorted(by_words.values(), key=lambda s: -len(s.numbers))
