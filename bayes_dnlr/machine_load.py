"""How busy the machine is at this instant: whether a second core is free for this process.

The kernel's count of runnable tasks (Linux /proc/loadavg, 4th field) says it now; the load
averages lag by a minute and still count, for instance, the ``sample`` that ran just before.
"""

from __future__ import annotations

import os
import time

READS = 3                   # the count read this many times, READ_GAP_S apart: the least is kept
READ_GAP_S = 0.001


def _runnable_now() -> int:
    with open("/proc/loadavg") as f:
        return int(f.read().split()[3].split("/")[0])


def other_runnable() -> float:
    """How many other tasks want a core now: the kernel's count of runnable tasks (this process
    included, so one less), else the 1-minute load average. The least of ``READS`` counts over
    2 ms: a task runnable for an instant (a kernel thread, a process exiting) is not a load, and it
    made the report draw its figures one by one on an idle machine now and then."""
    try:
        counts = []
        for i in range(READS):
            if i:
                time.sleep(READ_GAP_S)
            counts.append(_runnable_now())
        return max(0, min(counts) - 1)
    except (OSError, IndexError, ValueError):
        try:
            return os.getloadavg()[0]
        except OSError:         # pragma: no cover - no load figure on this system
            return float("inf")
