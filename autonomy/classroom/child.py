"""A call run in a new Python process of its own: what a Dask worker that runs as a daemon grades through.

A daemonic process (a Dask worker, by default) may not start a multiprocessing child, so it cannot
grade as this machine does, in limited worker processes of its own. It may start a subprocess: the
call is sent there, pickled on standard input; the child, an ordinary process, grades as here (its
own limited worker processes, the same marks) and sends the result back, pickled on standard output.
Nothing but the grader's own objects crosses: the pickles come from, and go to, the grader alone.
"""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
import threading
from collections.abc import Callable
from typing import Any, TypeVar

from autonomy.clock import RealClock

T = TypeVar("T")


class ChildFailed(RuntimeError):
    """The child process ended without a result: its exit code and the last line it said."""


def child_command() -> list[str]:
    """The command that starts a child for this process: it names this process, which it ends with.

    The child is named its parent, rather than asking who that is once it has started: a parent killed
    while the child still imports would leave it adopted by another process, which it would then outlive
    as it would its parent.
    """
    return [
        sys.executable,
        "-c",
        "import sys; from autonomy.classroom.child import serve; serve(int(sys.argv[1]))",
        str(os.getpid()),
    ]


def call_in_child(function: Callable[..., T], *args: Any) -> T:
    """``function(*args)``, called in a new Python process (a subprocess, which a daemon may start).

    Raises:
        ChildFailed: the child ended without a result.
    """
    done = subprocess.run(  # noqa: S603 - this interpreter, this module, the grader's own call
        child_command(),
        input=pickle.dumps((function, args)),
        capture_output=True,
        check=False,
    )
    if done.returncode != 0 or not done.stdout:
        said = done.stderr.decode("utf-8", "replace").strip().splitlines()
        raise ChildFailed(f"the grading process ended with code {done.returncode}: {said[-1] if said else 'no word'}")
    return pickle.loads(done.stdout)  # noqa: S301 - written by the child this call started


def alive(pid: int) -> bool:
    """Whether process ``pid`` still runs (one ended but not yet reaped by its parent, a zombie, does not)."""
    try:
        os.kill(pid, 0)
    except (ProcessLookupError, PermissionError):  # gone (or another's process has its number now)
        return False
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii", errors="replace") as stat:
            return stat.read().rsplit(")", 1)[-1].split()[0] != "Z"
    except (OSError, IndexError):  # no /proc here: it answered, so it runs
        return True


def end_with(pid: int, every_s: float = 0.5) -> None:
    """Ends this process (``os._exit``) soon after process ``pid`` is gone: a thread looks every ``every_s``.

    For a process whose only purpose is to answer ``pid``: killed outright, ``pid`` cannot end it, and
    nothing would ever read what it makes.
    """

    def watch() -> None:
        clock = RealClock()
        while alive(pid):
            clock.sleep(every_s)
        os._exit(1)

    threading.Thread(target=watch, name=f"ends with {pid}", daemon=True).start()


def serve(parent_pid: int) -> None:
    """The child's body: the call from standard input, its result to standard output (nothing else goes there).

    It ends with the process that started it, ``parent_pid`` (a Dask worker ended under it: nothing waits
    for its result), at once if that one is gone already.
    """
    if os.getppid() != parent_pid:  # killed while this process started: adopted by another
        os._exit(1)
    end_with(parent_pid)
    out = os.fdopen(os.dup(sys.stdout.fileno()), "wb")
    sys.stdout = sys.stderr  # whatever the call prints is not the result
    function, args = pickle.load(sys.stdin.buffer)  # noqa: S301 - sent by the grader that started this process
    result = function(*args)
    pickle.dump(result, out)
    out.close()
