"""The limits of one submission's grading: its CPU time (the kernel's count, never wall time) and its memory.

A worker process arms :data:`ALARM` for each submission and takes SIGPROF, from
:func:`autonomy.clock.cpu_alarm`, as :func:`on_cpu_limit`: the submission's grading ends with
:class:`CpuExhausted`, the robot stopped on the way, and a third signal ends the worker with
``CPU_EXIT_CODE``. CPU time, not wall time: a submission's work costs it the same CPU time however
many workers share however few cores, so its marks do not depend on the machine's load.
"""

from __future__ import annotations

import math
import os
import resource
from dataclasses import dataclass

from autonomy.classroom.exercise import Exercise

#: CPU time one submission (all its seeds) may take by default, seconds.
DEFAULT_CPU_S = 60.0


#: Wall time a submission may take by default, as a multiple of its CPU time: only one that waits
#: without working (a plugin that sleeps) meets it, whatever the number of workers and the load.
WALL_PER_CPU = 10.0


#: CPU time a worker gets past the limit to stop the robot and send its report (then it is told again), seconds.
CPU_GRACE_S = 1.0


#: How a worker ends whose submission went on after it was told twice that its CPU time was used up.
CPU_EXIT_CODE = 75


#: Memory one submission's worker may take by default, MiB.
DEFAULT_MEMORY_MB = 1024


#: How much more memory than it started with a worker may hold after a submission and grade the next, MiB.
RETIRE_GROWTH_MB = 32


def default_cpu_s(exercise: Exercise) -> float:
    """The CPU time a submission gets by default: 60 s, or more when its seeds add up to a long time.

    Runs go at 100 times real time or faster on a slow machine; a submission gets twice what
    that needs, so a long exercise does not cost a correct mission its marks.
    """
    return max(DEFAULT_CPU_S, 2 * len(exercise.seeds) * exercise.time_limit_s / 100)


class CpuExhausted(BaseException):
    """Raised in a worker whose submission has used the CPU time it may (SIGPROF, from :func:`cpu_alarm`).

    A ``BaseException``, so that neither a behaviour's ``except Exception`` nor the runner's ends it
    as a crash of the run: it ends the submission's grading, the robot stopped on the way.
    """


@dataclass
class _CpuAlarm:
    """The worker's CPU alarm: whether it is armed for a submission, and how often it has gone off since."""

    armed: bool = False
    rung: int = 0


#: The worker's CPU alarm (one a process).
ALARM = _CpuAlarm()


def on_cpu_limit(*_: object) -> None:
    """SIGPROF: the submission's CPU time is used up (and again every ``CPU_GRACE_S`` while it goes on).

    Told a third time, the submission's code has kept the exception twice: the worker ends at once,
    with ``CPU_EXIT_CODE``, which the grader reads as this same reason. A signal that comes once the
    submission is over (the alarm disarmed) is let go.
    """
    if not ALARM.armed:
        return
    ALARM.rung += 1
    if ALARM.rung > 2:
        os._exit(CPU_EXIT_CODE)
    raise CpuExhausted


def cap_what_it_starts(cpu_s: float) -> None:
    """Limits each process a plugin starts to about the submission's CPU time: SIGXCPU, then SIGKILL.

    The processes a plugin starts inherit the limit, each counting its own CPU time, which the
    worker's alarm does not see. The worker (which, plugins allowed, grades one submission) meets
    its alarm first: its own limit lies two seconds past the alarm's third time.
    """
    soft = math.ceil(cpu_s + 2 * CPU_GRACE_S) + 2
    try:
        resource.setrlimit(resource.RLIMIT_CPU, (soft, soft + 1))
    except (ValueError, OSError):
        pass


def cpu_used_up_why(cpu_s: float) -> str:
    """Why a submission that used up its CPU time scores nothing."""
    why = f"used more than {cpu_s:g} s of CPU time: an endless loop, or a tree too big to run in time"
    return f"{why} (--cpu-seconds gives more)"


def address_space_mb() -> float | None:
    """How much address space this process holds (what its memory limit counts), MiB; None where unknown."""
    try:
        with open("/proc/self/statm", encoding="ascii") as statm:
            return int(statm.read().split()[0]) * resource.getpagesize() / 2**20
    except (OSError, ValueError, IndexError):
        return None
