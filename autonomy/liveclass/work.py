"""What the class's server does with a student's mission text: check it, and say where its problems are.

Nothing here runs a student's Python: plugins are refused, as in grading.
"""

from __future__ import annotations

import dataclasses
import queue
import tempfile
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

from autonomy.behaviours.tree import describe_tree
from autonomy.classroom.cluster import connect, in_a_daemon, results
from autonomy.classroom.exercise import Exercise
from autonomy.classroom.job import PLUGINS_REFUSED, check_text
from autonomy.classroom.limits import DEFAULT_CPU_S
from autonomy.classroom.pool import grade_class
from autonomy.classroom.results import Report, file_names, page_path
from autonomy.classroom.warm import WarmWorkers
from autonomy.mission import BUILTINS, MissionInvalid, build_tree
from autonomy.mission.blocks import (
    block_at_line,
    block_definitions,
    from_workspace,
    problems_at_blocks,
    read_json,
    to_workspace,
    toolbox,
    workspace_json,
)
from autonomy.mission.catalogue import json_schema, node_help
from autonomy.source import Problem
from autonomy.views.lines import printable
from autonomy.views.mapsvg import world_svg
from autonomy.views.treesvg import svg_tree

#: How a student's mission is named in its problems.
MISSION_LABEL = "mission.yaml"
#: Longest mission text taken (a mission file may be 500,000 bytes; a class's are a few hundred).
MAX_MISSION_CHARS = 100_000
#: How far behind the server a grading's process runs (``os.nice``): on a machine busy grading, the server
#: answers its students' checks first. A grading's CPU time, and so its marks, are the same.
GRADING_NICENESS = 10
#: Problems a check's answer lists; past them, one says how many more there are.
PROBLEMS_SHOWN = 20
#: Most nodes in a class's mission (its replays, on every seed, grow with them: a class's have a few dozen).
MAX_NODES = 500


def check(exercise: Exercise, text: str) -> dict[str, Any]:
    """The ``api/check`` answer: each problem at its line and column, or the tree drawn.

    Returns:
        ``{"ok": bool, "problems": [{"line", "column", "path", "message"}...], "tree_svg": str}``; the
        tree is drawn only for a mission without problems.
    """
    if len(text) > MAX_MISSION_CHARS:
        return _refused(f"the mission is {len(text):,} characters long; at most {MAX_MISSION_CHARS:,} are taken")
    spec, problems = check_text(exercise, text, MISSION_LABEL, NO_PLUGINS)
    if spec is None:
        return _refused(*problems)
    nodes = describe_tree(build_tree(spec))
    if len(nodes) > MAX_NODES:
        return _refused(f"the tree has {len(nodes):,} nodes; a class's mission has at most {MAX_NODES:,}", path="tree")
    return {"ok": True, "problems": [], "tree_svg": svg_tree(nodes, spec.name)}


#: Where a student's mission's plugins would be: nowhere (they are refused, never imported).
NO_PLUGINS = Path("/nonexistent-plugins")


def as_blocks(exercise: Exercise, text: str, line: int | None = None) -> dict[str, Any]:
    """The ``api/blocks`` answer: the mission as Blockly's JSON of a workspace, or its problems (it stays text).

    With the ``line`` the text's cursor is on, ``selected`` is the block of the node there (None: none).
    """
    checked = check(exercise, text)
    if not checked["ok"]:
        return {"ok": False, "problems": checked["problems"]}
    spec, _ = check_text(exercise, text, MISSION_LABEL, NO_PLUGINS)
    if spec is None:
        return _refused("not a mission")
    placed: dict[str, tuple[int, int]] = {}
    workspace = to_workspace(spec, text, placed)
    return {"ok": True, "workspace": workspace, "selected": None if line is None else block_at_line(placed, line)}


def as_text(exercise: Exercise, body: bytes, selected: str | None = None) -> dict[str, Any]:
    """The ``api/text`` answer to a body ``{"workspace": ...}``: the mission's canonical text, or its problems.

    A problem of the blocks names its block (``block``: its id); one of the text they make (a node the
    exercise does not allow) is at its line and column of that text. With the ``selected`` block's id,
    ``line`` is the line of the text its node begins on (None: no such block).
    """
    try:
        sent = read_json(body)
    except (ValueError, RecursionError):
        return _refused('the body is JSON: {"workspace": the blocks, as Blockly saves them}')
    workspace = sent.get("workspace") if isinstance(sent, dict) else None
    if not isinstance(workspace, dict):
        return _refused('the body is JSON: {"workspace": the blocks, as Blockly saves them}')
    try:
        written = workspace_json(workspace)
        lines: dict[str, int] = {}
        text, _ = from_workspace(
            written, "the blocks", base_dir=NO_PLUGINS, refuse_plugins=PLUGINS_REFUSED, lines=lines
        )
    except MissionInvalid as err:
        return {"ok": False, "problems": problems_at_blocks(written, err.problems)}
    except (RecursionError, ValueError, TypeError):
        return _refused("the blocks are nested deeper than a mission goes")
    checked = check(exercise, text)
    if not checked["ok"]:
        return {"ok": False, "problems": [{**p, "block": None} for p in checked["problems"]], "mission": text}
    return {"ok": True, "mission": text, "line": lines.get(selected) if selected else None}


def palette(exercise: Exercise) -> dict[str, Any]:
    """What a student's page writes a mission with: its blocks, its toolbox, its text's completions.

    The blocks are every node's (to show any mission); the toolbox and the JSON Schema the text's completions
    come from hold the exercise's nodes alone.
    """
    return {
        "blocks": block_definitions(BUILTINS),
        "toolbox": toolbox(BUILTINS, allowed=exercise.allowed_nodes),
        "schema": json_schema(BUILTINS, allowed=exercise.allowed_nodes),
    }


def _refused(*problems: Problem | str, path: str = "") -> dict[str, Any]:
    """The ``api/check`` answer of a mission with problems: each a :class:`Problem`, or a message about the whole.

    The first :data:`PROBLEMS_SHOWN` are sent, then one saying how many more there are, at the next's line:
    a text of a thousand mistakes costs the answer no more than twenty (``problems_in_all`` counts them all).
    """
    shown = [
        {"line": p.line, "column": p.column, "path": p.path, "message": p.message}
        if isinstance(p, Problem)
        else {"line": 1, "column": 1, "path": path, "message": p}
        for p in problems[: PROBLEMS_SHOWN + 1]
    ]
    if len(problems) > PROBLEMS_SHOWN:
        more = len(problems) - PROBLEMS_SHOWN
        message = f"and {more:,} more problem{'s' if more > 1 else ''} from here: fix these first, then check again"
        shown[PROBLEMS_SHOWN] = {**shown[PROBLEMS_SHOWN], "path": "", "message": message}
    return {"ok": False, "problems": shown, "problems_in_all": len(problems), "tree_svg": ""}


def exercise_shown(exercise: Exercise) -> dict[str, Any]:
    """What a student is shown of the exercise: its text, its world drawn, its criteria, how many seeds, its nodes."""
    hidden = sum(1 for seed in exercise.seeds if seed.hidden)
    return {
        "name": printable(exercise.name),
        "title": printable(exercise.title),
        "description": "\n".join(printable(line) for line in exercise.description.splitlines()),
        "world_svg": world_svg(exercise.world.as_dict(), f"the world of {exercise.title}"),
        "time_limit_s": exercise.time_limit_s,
        "criteria": [{"label": printable(c.shown), "points": c.points} for c in exercise.criteria],
        "max_points": exercise.max_points,
        "robot_points": exercise.robot_points,
        "public_seeds": len(exercise.seeds) - hidden,
        "hidden_seeds": hidden,
        "allowed_nodes": list(exercise.allowed_nodes) if exercise.allowed_nodes is not None else None,
        "nodes": node_help(BUILTINS, exercise.allowed_nodes),
    }


def page_file(folder: Path, student: str, number: int) -> Path:
    """Where the feedback page of a student's work numbered ``number`` is kept in the class's folder."""
    name = f"{file_names([student])[student]}-{number}"
    return page_path(folder / "pages", file_names([name])[name])


def public_only(exercise: Exercise) -> Exercise:
    """The exercise with its public seeds alone: what a student's "Run" is tried on."""
    return dataclasses.replace(exercise, seeds=[seed for seed in exercise.seeds if not seed.hidden])


def grade_text(
    exercise: Exercise,
    student: str,
    text: str,
    folder: Path,
    number: int,
    hand_in: bool,
    label: str = "",
    cpu_s: float | None = None,
    workers: WarmWorkers | None = None,
) -> tuple[Report, Path]:
    """Grades a student's mission text as ``autonomy grade`` does, in a limited worker process.

    The text is kept as ``FOLDER/works/NAME/NUMBER-run.yaml`` (or ``-handin``), and its feedback page,
    with each seed's replay, written to :func:`page_file`. The report and the page name the file
    ``NUMBER-run.yaml``: where the class's folder is is none of the student's business.

    Args:
        exercise: The exercise, with its hidden seeds when it has them (see :meth:`Exercise.with_secret`).
        student: The student's id.
        text: The mission's text.
        folder: The class's folder.
        number: The work's number in the class's store, which names its files.
        hand_in: Graded on every seed; otherwise ("Run") on the public seeds alone.
        label: Who the report and the page say it is (``hand-in 3``: a page may be projected); default
            the student's id and the number.
        cpu_s: The CPU time the grading may take (default :data:`~autonomy.classroom.limits.DEFAULT_CPU_S`).
        workers: A worker kept warm for the class (see :class:`LocalGrader`), with the exercise as ``all`` and
            its public seeds as ``public``; default: a worker started for this grading alone.

    Returns:
        The report, and the feedback page's path.
    """
    kept = _keep(folder, student, text, number, hand_in)
    label = label or f"{file_names([student])[student]}-{number}"
    made = folder / "pages" / f".{number}"  # the page is made apart, then put where it is kept
    made.mkdir(parents=True, exist_ok=True)
    name = file_names([label])[label]
    if workers is not None:
        report = workers.grade("all" if hand_in else "public", label, kept, made, name, cpu_s or DEFAULT_CPU_S)
    else:
        graded = exercise if hand_in else public_only(exercise)
        limits = {} if cpu_s is None else {"cpu_s": cpu_s}
        (report,) = grade_class(
            graded, [(label, kept)], workers=1, feedback=made, start_method="forkserver", by_name=True,
            niceness=GRADING_NICENESS, **limits,
        )  # fmt: skip
    page = page_file(folder, student, number)
    try:
        page_path(made, name).replace(page)
    finally:
        for left in made.iterdir():
            left.unlink()
        made.rmdir()
    return report, page


def work_file(folder: Path, student: str, number: int, hand_in: bool) -> Path:
    """Where a work's text is kept: ``FOLDER/works/NAME/NUMBER-run.yaml`` (or ``-handin``)."""
    return folder / "works" / file_names([student])[student] / f"{number}-{'handin' if hand_in else 'run'}.yaml"


def _keep(folder: Path, student: str, text: str, number: int, hand_in: bool) -> Path:
    """Keeps a work's text where :func:`work_file` says; its path."""
    kept = work_file(folder, student, number, hand_in)
    kept.parent.mkdir(parents=True, exist_ok=True)
    kept.write_text(text, encoding="utf-8")
    return kept


def grade_on_worker(
    exercise: Exercise, student: str, text: str, number: int, hand_in: bool, label: str = "", cpu_s: float | None = None
) -> tuple[Report, bytes]:
    """:func:`grade_text` on a Dask worker, in a folder of its own there: the report, and the feedback page's bytes."""
    if in_a_daemon():  # graded in a process of its own, for this work alone (see child.py): nothing kept warm
        from autonomy.classroom.child import call_in_child

        return call_in_child(_graded_by, grade_text, exercise, student, text, number, hand_in, label, cpu_s)
    return _graded_by(_warm_for(exercise), exercise, student, text, number, hand_in, label, cpu_s)


def _graded_by(
    grader: Callable[..., tuple[Report, Path]], exercise: Exercise, student: str, text: str, number: int,
    hand_in: bool, label: str, cpu_s: float | None,
) -> tuple[Report, bytes]:  # fmt: skip
    """A work graded by ``grader`` (``grade_text``'s arguments) in a folder of its own: the report, the page's bytes."""
    with tempfile.TemporaryDirectory(prefix="autonomy-class-") as folder:
        report, page = grader(exercise, student, text, Path(folder), number, hand_in, label, cpu_s)
        return report, page.read_bytes()


#: Exercises a Dask worker keeps warm workers for at once (a cluster may grade several classes).
WARM_EXERCISES = 4
#: On a Dask worker: each exercise's warm workers, by the exercise (sent once, as :class:`DaskGrader` does).
_WARM: dict[int, LocalGrader] = {}
_WARM_LOCK = threading.Lock()


def _warm_for(exercise: Exercise) -> LocalGrader:
    """The warm workers of ``exercise`` in this process, started at its first grading; as many as its threads."""
    with _WARM_LOCK:
        grader = _WARM.get(id(exercise))
        if grader is not None:
            _WARM[id(exercise)] = _WARM.pop(id(exercise))  # the last used, last to go
        else:
            try:
                from distributed import get_worker

                lanes = get_worker().state.nthreads
            except (ImportError, ValueError, AttributeError):
                lanes = 1
            while len(_WARM) >= WARM_EXERCISES:  # the least lately used class's go, once their gradings end
                threading.Thread(target=_WARM.pop(next(iter(_WARM))).retire, daemon=True).start()
            grader = _WARM[id(exercise)] = LocalGrader(exercise, lanes=max(1, lanes))
        return grader


class LocalGrader:
    """Grades the class's works on this machine as :func:`grade_text` does, in workers kept warm between works.

    Each of the server's lanes grades one work at a time: there is one worker for each, started once and
    kept while nothing a work did could have changed it (see :class:`~autonomy.classroom.warm.WarmWorkers`),
    with the same limits, the same marks and the same page as a worker started for each work.

    Args:
        exercise: The class's exercise, with its hidden seeds drawn.
        lanes: How many gradings at once (a worker each).
    """

    def __init__(self, exercise: Exercise, lanes: int) -> None:
        self._exercise = exercise
        exercises = {"all": exercise, "public": public_only(exercise)}
        self._all = [WarmWorkers(exercises, niceness=GRADING_NICENESS) for _ in range(lanes)]
        self._free: queue.SimpleQueue[WarmWorkers] = queue.SimpleQueue()
        for workers in self._all:
            self._free.put(workers)
        self._closed = False

    def start(self) -> None:
        """Starts every worker now, so that the first works do not wait for theirs."""
        for workers in self._all:
            workers.start()

    def __call__(
        self,
        exercise: Exercise,
        student: str,
        text: str,
        folder: Path,
        number: int,
        hand_in: bool,
        label: str = "",
        cpu_s: float | None = None,
    ) -> tuple[Report, Path]:
        """Grades one work as :func:`grade_text` does, in a warm worker (in one of its own for another exercise)."""
        if self._closed:
            raise RuntimeError("the grading workers were closed")
        if exercise is not self._exercise:
            return grade_text(exercise, student, text, folder, number, hand_in, label, cpu_s)
        workers = self._free.get()
        try:
            if workers.closed:  # retired (see :meth:`retire`): a worker of its own
                return grade_text(exercise, student, text, folder, number, hand_in, label, cpu_s)
            return grade_text(exercise, student, text, folder, number, hand_in, label, cpu_s, workers)
        finally:
            self._free.put(workers)

    def close(self) -> None:
        """Ends the workers (a grading under way raises, as any after this does)."""
        self._closed = True
        for workers in self._all:
            workers.close()

    def retire(self) -> None:
        """Ends each worker once its grading under way, if any, has ended; a grading after is done cold."""
        for _ in self._all:
            workers = self._free.get()
            workers.close()
            self._free.put(workers)


class DaskGrader:
    """Grades the class's works on a Dask cluster, as :func:`grade_text` does here (the same marks, the same page).

    The workers need this ``autonomy`` installed; as Dask starts them, with its defaults, is as good as any
    (a worker that runs as a daemon grades in a process of its own: see :mod:`autonomy.classroom.child`).
    A grading raises :class:`~autonomy.classroom.cluster.ClusterUnfit` when the cluster loses every
    worker and none comes back in time, or the grading fails there.

    Args:
        address: The scheduler's address (``tcp://host:8786``).

    Raises:
        ImportError: ``dask.distributed`` is not installed (``pip install 'autonomy[cluster]'``).
        OSError: no scheduler answers at ``address``.
        ClusterUnfit: the cluster has no worker, or one without this autonomy (see :func:`connect`).
    """

    def __init__(self, address: str) -> None:
        self._address = address
        self._client = connect(address)
        self._exercise: tuple[Exercise, Any] | None = None  # sent to every worker once, and kept there
        #: The gradings the cluster does at once: its workers' threads when it was joined.
        self.slots = max(1, sum(w.get("nthreads", 1) for w in self._client.scheduler_info()["workers"].values()))

    def _sent(self, exercise: Exercise) -> Any:
        """The exercise as the workers hold it (sent at its first grading): each keeps its warm workers for it."""
        if self._exercise is None or self._exercise[0] is not exercise:
            self._exercise = (exercise, self._client.scatter(exercise, broadcast=True, hash=False))
        return self._exercise[1]

    def __call__(
        self,
        exercise: Exercise,
        student: str,
        text: str,
        folder: Path,
        number: int,
        hand_in: bool,
        label: str = "",
        cpu_s: float | None = None,
    ) -> tuple[Report, Path]:
        """Grades one work on the cluster; keeps its text and its page in ``folder`` as :func:`grade_text` does."""
        _keep(folder, student, text, number, hand_in)
        task = self._client.submit(
            grade_on_worker, self._sent(exercise), student, text, number, hand_in, label, cpu_s, pure=False
        )
        ((_, (report, page)),) = results(self._client, [task], self._address)
        path = page_file(folder, student, number)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(page)
        return report, path

    def close(self) -> None:
        """Lets the cluster go."""
        self._client.close()
