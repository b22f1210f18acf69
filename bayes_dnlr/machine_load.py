"""How busy the machine is at this instant: whether a second core is free for this process.

The kernel's count of runnable tasks (Linux /proc/loadavg, 4th field) says it now; the load
averages lag by a minute and still count, for instance, the ``sample`` that ran just before.
"""

from __future__ import annotations

import os


def other_runnable() -> float:
    """How many other tasks want a core now: the kernel's count of runnable tasks (this process
    included, so one less), else the 1-minute load average."""
    try:
        with open("/proc/loadavg") as f:
            return max(0, int(f.read().split()[3].split("/")[0]) - 1)
    except (OSError, IndexError, ValueError):
        try:
            return os.getloadavg()[0]
        except OSError:         # pragma: no cover - no load figure on this system
            return float("inf")
