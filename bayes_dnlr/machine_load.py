"""How busy the machine is at this instant: whether a second core is free for this process.

The kernel's count of runnable tasks (Linux /proc/loadavg, 4th field) says it now; the load
averages lag by a minute and still count, for instance, the ``sample`` that ran just before. The
count includes this process's own threads: the one asking, and a thread of numba's OpenMP pool
still spinning for a moment after a parallel call (model/threads.py), which is not another task's
load (after ``sample`` in the same process, it took the report's figure worker away now and then).
"""

from __future__ import annotations

import os
import time

READS = 3                   # the count read this many times, READ_GAP_S apart: the least is kept
READ_GAP_S = 0.001


def _runnable_now() -> int:
    with open("/proc/loadavg") as f:
        return int(f.read().split()[3].split("/")[0])


def own_runnable(tasks: str = "/proc/self/task") -> int:
    """This process's threads that are running or ready to run (state R): at least 1, the one
    asking (also where ``tasks`` cannot be read)."""
    n = 0
    try:
        entries = list(os.scandir(tasks))
    except OSError:
        return 1
    for task in entries:
        try:
            with open(os.path.join(task.path, "stat")) as f:
                stat = f.read()
        except OSError:        # a thread that ended since the listing
            continue
        n += stat[stat.rindex(")") + 2:].startswith("R")
    return max(n, 1)


def other_runnable() -> float:
    """How many other tasks want a core now: the kernel's count of runnable tasks less this
    process's own (``own_runnable``), else the 1-minute load average. The least of ``READS``
    counts over 2 ms: a task runnable for an instant (a kernel thread, a process exiting) is not a
    load, and it made the report draw its figures one by one on an idle machine now and then."""
    try:
        counts = []
        for i in range(READS):
            if i:
                time.sleep(READ_GAP_S)
            counts.append(_runnable_now() - own_runnable())
        return max(0, min(counts))
    except (OSError, IndexError, ValueError):
        try:
            return os.getloadavg()[0]
        except OSError:         # pragma: no cover - no load figure on this system
            return float("inf")
