"""Grading: every submission of a class run on every seed of an exercise, judged and marked.

Submissions are graded in worker processes, with a CPU-time limit for each submission and a
memory limit for each worker, so that an endless loop, a crash or a huge file costs that
student a zero with the reason, never the batch. CPU time, not wall time: a submission's work
costs it the same CPU time however many workers share however few cores, so its marks do not
depend on the machine's load. Wall time, ten times as long, only ends one that waits without
working (a plugin that sleeps). A worker grades one submission after another
while nothing of them could have changed it, and is replaced otherwise (see :func:`_worker`).
Every run is in virtual time on the in-process emulator, seeded: grading twice gives the same
marks, byte for byte. Python plugins in a submission are refused (before anything of them is
imported) unless the teacher allows them.
"""

from __future__ import annotations

import gc
import math
import multiprocessing
import os
import resource
import signal
import traceback
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from multiprocessing.connection import Connection, wait
from pathlib import Path
from typing import Any, cast
from urllib.parse import urlencode

from py_trees.blackboard import Blackboard

from autonomy.classroom.exercise import Exercise, Seed
from autonomy.classroom.judge import Gatherer, RunFacts, Verdict, facts_of, judge, path_points
from autonomy.classroom.results import Report, SeedResult, file_names
from autonomy.client import Client
from autonomy.clock import RealClock, cpu_alarm, cpu_time_s
from autonomy.errors import LinkError
from autonomy.mission import MissionInvalid, MissionSpec, NodeSpec, Problem, validate_text
from autonomy.runner import Runner
from autonomy.source import UnreadableFile, read_text
from autonomy.trace import TraceWriter
from autonomy.views.page import ReplayMaker

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
#: Why a submission's plugins are refused (YAML's ``plugins:`` or XML's ``_plugins``): nothing of them is imported.
PLUGINS_REFUSED = (
    "Python plugins are not run when grading unless the teacher allows them (autonomy grade --allow-plugins)"
)


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


_cpu = _CpuAlarm()


def _on_cpu_limit(*_: object) -> None:
    """SIGPROF: the submission's CPU time is used up (and again every ``CPU_GRACE_S`` while it goes on).

    Told a third time, the submission's code has kept the exception twice: the worker ends at once,
    with ``CPU_EXIT_CODE``, which the grader reads as this same reason. A signal that comes once the
    submission is over (the alarm disarmed) is let go.
    """
    if not _cpu.armed:
        return
    _cpu.rung += 1
    if _cpu.rung > 2:
        os._exit(CPU_EXIT_CODE)
    raise CpuExhausted


def _cap_what_it_starts(cpu_s: float) -> None:
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


def _cpu_used_up_why(cpu_s: float) -> str:
    """Why a submission that used up its CPU time scores nothing."""
    why = f"used more than {cpu_s:g} s of CPU time: an endless loop, or a tree too big to run in time"
    return f"{why} (--cpu-seconds gives more)"


def find_submissions(paths: Iterable[str | Path]) -> list[tuple[str, Path]]:
    """(student, path) for each submission: a mission file, or a folder of one student's files.

    A folder's student is the folder's name and its mission is its one ``.yaml`` file (or
    ``mission.yaml`` when it has several). Students of the same name (``a/alice.yaml``,
    ``b/alice.yaml``; ``alice/hw2/mission.yaml``, ``bob/hw2/mission.yaml``) are told apart by
    as many of their folders as it takes. The bytes of a name that are not UTF-8 are written
    out (``lat\\xe9in``). Files are sorted by student, so reports are too.
    """
    given = [Path(raw) for raw in paths]
    choices = [_names(path) for path in given]
    level = [0] * len(given)
    while True:
        seen: dict[str, list[int]] = {}
        for index, names in enumerate(choices):
            seen.setdefault(names[level[index]], []).append(index)
        further = [i for group in seen.values() if len(group) > 1 for i in group if level[i] + 1 < len(choices[i])]
        if not further:  # all told apart, or nothing left to tell them apart by (the same file given twice)
            break
        for index in further:
            level[index] += 1
    found = [(names[level[index]], path) for index, (names, path) in enumerate(zip(choices, given, strict=True))]
    return sorted(found, key=lambda item: (item[0], str(item[1])))


def _names(path: Path) -> list[str]:
    """A submission's student, then with more and more of its folders, then the path as given.

    The student is a file's name without its suffix, or a folder's name (``.`` is the folder it names).
    """
    name = path.stem if path.is_file() or path.suffix in (".yaml", ".yml") else path.name
    whole = Path(os.path.abspath(path))
    folders = [_readable(part) for part in whole.parent.parts[1:]]
    name = _readable(name or whole.name or str(path))
    # past the top folder, the path as given (alice.yml beside a folder alice/) tells them apart
    return [name, *("/".join([*folders[-depth:], name]) for depth in range(1, len(folders) + 1)), _readable(str(path))]


def _readable(text: str) -> str:
    r"""``text`` as valid Unicode: the bytes of a file name that are not UTF-8 written out (``lat\xe9in``).

    Written out, not replaced: two names that differ only there stay two names.
    """
    return text.encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")


#: What a mission file is called: YAML, or BehaviorTree.CPP's XML (any case: ``PARK.YAML``).
MISSION_SUFFIXES = (".yaml", ".yml", ".xml")


def _mission_file(path: Path) -> tuple[Path | None, str]:
    if not path.exists() and not path.is_symlink():
        return None, f"{path}: no such file or folder"
    if path.is_file() or path.is_symlink():
        return path, ""
    if not path.is_dir():
        return None, f"{path}: not a mission file nor a folder"

    def missions(folder: Path) -> list[Path]:
        return sorted(
            p
            for p in folder.iterdir()
            if p.suffix.lower() in MISSION_SUFFIXES and not p.name.startswith(".") and p.is_file()
        )

    candidates = missions(path)
    if not candidates:  # a zipped folder unpacked: the files one folder down
        inner = [p for p in path.iterdir() if p.is_dir() and not p.name.startswith((".", "__"))]
        if len(inner) == 1:
            candidates = missions(inner[0])
    if len(candidates) == 1:
        return candidates[0], ""
    named = [p for p in candidates if p.stem == "mission"]
    if named:
        return named[0], ""
    if not candidates:
        found = sorted(p.name for p in path.iterdir() if not p.name.startswith("."))[:5]
        there = f" (it holds {', '.join(found)})" if found else " (it is empty)"
        return None, f"{path}: no mission file (.yaml, .yml or .xml) in the folder{there}"
    listed = ", ".join(p.name for p in candidates)
    return None, f"{path}: several mission files ({listed}); name the one to grade mission.yaml"


def _nodes(spec: MissionSpec) -> Iterable[NodeSpec]:
    stack = [spec.tree, *spec.subtrees.values()]
    while stack:
        node = stack.pop()
        yield node
        stack.extend(node.children)


def tree_shape(spec: MissionSpec) -> tuple[str, ...]:
    """The mission's tree as a sequence of tokens, subtrees written out, numbers and names left out.

    Each node is its type with the arguments that are words (``move direction=backward``), then
    ``(`` its children ``)``: two trees with the same tokens are the same but for numbers and names.
    """
    tokens: list[str] = []

    def walk(node: NodeSpec, depth: int) -> None:
        if node.type.name == "subtree" and depth < 20:
            inner = spec.subtrees.get(str(node.args.get("subtree", "")))
            if inner is not None:
                walk(inner, depth + 1)
                return
        words = [
            f"{key}={value}"
            for key, value in sorted(node.args.items())
            if isinstance(value, (str, bool)) and key not in ("subtree", "name", "message", "text")
        ]
        tokens.append(" ".join([node.type.name, *words]))
        if node.children:
            tokens.append("(")
            for child in node.children:
                walk(child, depth)
            tokens.append(")")

    walk(spec.tree, 0)
    return tuple(tokens)


def check_submission(exercise: Exercise, path: Path, allow_plugins: bool) -> tuple[MissionSpec | None, list[str]]:
    """Validates a submission for ``exercise`` without running any of its Python.

    Returns:
        The validated mission, or None and every problem (``FILE:LINE:COL: ...`` lines).
    """
    label = str(path)
    if path.is_symlink():
        return None, [f"{label}:1:1: a link, not a file: hand in the mission file itself"]
    try:
        text = read_text(path)
    except UnreadableFile as err:
        return None, [f"{label}:{err.line}:{err.column}: cannot read the file: {err.reason}"]
    spec, problems = check_text(exercise, text, label, path.parent, allow_plugins)
    return spec, [str(p) for p in problems]


def check_text(
    exercise: Exercise, text: str, label: str, base_dir: Path, allow_plugins: bool = False
) -> tuple[MissionSpec | None, list[Problem]]:
    """Validates a mission's text for ``exercise`` without running any of its Python.

    Args:
        exercise: The exercise: its allowed nodes.
        text: The mission file's text.
        label: How the file is named in problems.
        base_dir: Where the mission's plugins would be (refused unless ``allow_plugins``).
        allow_plugins: Whether plugins may be named.

    Returns:
        The validated mission, or None and every problem, in file order.
    """
    try:  # grading runs in the exercise's world: the mission's own is not loaded (nor echoed)
        spec = validate_text(
            text, label, base_dir, check_world=False, refuse_plugins=None if allow_plugins else PLUGINS_REFUSED
        )
    except MissionInvalid as err:
        return None, list(err.problems)
    if exercise.allowed_nodes is not None:
        allowed = set(exercise.allowed_nodes)
        listed = ", ".join(exercise.allowed_nodes)
        problems = [
            Problem(
                label,
                node.line,
                node.column,
                node.path,
                f"'{node.type.name}' is not allowed in this exercise (allowed: {listed})",
            )
            for node in _nodes(spec)
            if node.type.name not in allowed
        ]
        if problems:
            return None, sorted(problems, key=lambda p: (p.line, p.column))
    return spec, []


def run_seed(
    exercise: Exercise, spec: MissionSpec, seed: Seed, trace: Path | None = None, replay: ReplayMaker | None = None
) -> RunFacts:
    """Runs ``spec`` once on ``seed`` in the exercise's world, in virtual time; returns its facts.

    The facts are gathered as the records come, and the records let go: a long run is not
    held in memory (nor gone over again and again by the garbage collector). With ``trace``,
    the run is also written there as a trace, and with ``replay`` made into a page's replay (nodes'
    states included, either way).
    """
    options = {"world": exercise.world_ref, "seed": seed.seed, "time": "virtual", "noise": seed.noise_mm}
    # a world file's path may hold bytes that are not UTF-8: they go through the URL as they are
    query = urlencode({**options, "faults": seed.faults} if seed.faults else options, errors="surrogateescape")
    url = "emu://?" + query
    client = Client.open(url)
    gatherer = Gatherer()
    stream = trace.open("w", encoding="utf-8") if trace is not None else None
    try:
        listeners: list[Any] = [gatherer] + ([TraceWriter(stream)] if stream is not None else [])
        listeners += [replay] if replay is not None else []
        replayed = stream is not None or replay is not None
        runner = Runner.for_mission(
            spec, client, max_seconds=exercise.time_limit_s, listeners=listeners, node_states=replayed
        )  # the judge reads the emulator's own account: the nodes' states are looked for only for a replay
        runner.run()
        emulator = client.port.emulator  # type: ignore[attr-defined]  # an emu:// link's port has its emulator
        return facts_of(gatherer, emulator.robot, exercise.time_limit_s)
    finally:
        client.close()
        if stream is not None:
            stream.close()


def _seed_result(seed: Seed, facts: RunFacts, verdicts: list[Verdict], trace: str = "") -> SeedResult:
    """One run's result: the verdicts, and the path, collisions, beeps and turns to draw and list."""

    def at(time_s: float, x_mm: float, y_mm: float) -> tuple[float, float, float]:
        return round(time_s, 2), round(x_mm), round(y_mm)

    return SeedResult(
        seed.label,
        facts.outcome,
        round(facts.time_s, 2),
        [(v.held, v.line) for v in verdicts],
        [round(v.share, 4) for v in verdicts],
        path_points(facts),
        [at(t, p.x_mm, p.y_mm) for t, p in facts.collisions],
        [at(t, p.x_mm, p.y_mm) for t, p in facts.beeps],
        [(*at(turn.time_s, turn.x_mm, turn.y_mm), round(turn.degrees, 1)) for turn in facts.turns],
        None if facts.rest_s is None else round(facts.rest_s, 2),
        seed.seed,
        trace,
    )


def trace_path(folder: Path, name: str, seed: Seed) -> Path:
    """Where ``--traces`` keeps a student's run on one seed: ``FOLDER/NAME/seed-8.jsonl`` (see :func:`file_names`)."""
    return folder / name / (seed.label.split(" (")[0].replace(" ", "-") + ".jsonl")


def grade_one(
    exercise: Exercise,
    student: str,
    path: Path,
    allow_plugins: bool = False,
    traces: Path | None = None,
    runs: list[ReplayMaker] | None = None,
    name: str = "",
) -> Report:
    """Grades one submission on every seed (in this process).

    With ``traces``, each run's trace is kept there (under ``name``, the student's as a file's);
    with ``runs``, each seed's run is added to that list as its replay, for a page.
    """
    zero = [0.0] * len(exercise.criteria)
    mission, why = _mission_file(path)
    if mission is None:
        return Report(student, "", 0.0, exercise.max_points, zero, [why])
    spec, problems = check_submission(exercise, mission, allow_plugins)
    if spec is None:
        return Report(student, _readable(str(mission)), 0.0, exercise.max_points, zero, problems)
    seeds = []
    earned = [0.0] * len(exercise.criteria)
    for seed in exercise.seeds:
        kept = None
        if traces is not None:
            kept = trace_path(traces, name or file_names([student])[student], seed)
            kept.parent.mkdir(parents=True, exist_ok=True)
        replay = ReplayMaker() if runs is not None else None
        if runs is not None and replay is not None:
            runs.append(replay)
        try:
            facts = run_seed(exercise, spec, seed, kept, replay)
        except LinkError as err:  # the seed's link faults left no link to start on: that seed alone scores nothing
            why = f"no run: under this seed's faults the link failed before the mission started ({type(err).__name__})"
            none = len(exercise.criteria)
            seeds.append(
                SeedResult(seed.label, "no run", 0.0, [(False, why)] * none, [0.0] * none, world_seed=seed.seed)
            )
            continue
        world = exercise.world.for_seed(seed.seed)  # where this seed put what the world varies
        verdicts = _with_requirements(exercise, [judge(c, facts, world) for c in exercise.criteria])
        for index, verdict in enumerate(verdicts):
            earned[index] += verdict.share
        seeds.append(_seed_result(seed, facts, verdicts, str(kept) if kept is not None else ""))
    count = len(exercise.seeds)
    exact = [c.points * earned[i] / count for i, c in enumerate(exercise.criteria)]
    marks = [round(m, 2) for m in exact]
    notes = []
    if spec.world and spec.world not in (exercise.world_ref, exercise.world.name):
        shown = spec.world if len(spec.world) <= 60 else spec.world[:60] + "..."
        notes.append(
            f"the mission names the world '{shown}', which grading does not use: "
            f"every run is in the exercise's world '{exercise.world.name}'"
        )
    total = round(sum(exact), 2)
    report = Report(student, _readable(str(mission)), total, exercise.max_points, marks, [], seeds, notes)
    report.shape = list(tree_shape(spec))
    return report


def _with_requirements(exercise: Exercise, verdicts: list[Verdict]) -> list[Verdict]:
    """Each criterion that requires another holds only where that one (and what it requires) held.

    With ``requires_some``, where that one earned only a part (a near miss), this one earns the
    same part of what it would have.
    """

    def held(index: int, some: bool = False) -> bool:
        criterion = exercise.criteria[index]
        here = verdicts[index].share > 0 if some else verdicts[index].held
        return here and (criterion.requires is None or held(criterion.requires, criterion.requires_some))

    out = []
    for criterion, verdict in zip(exercise.criteria, verdicts, strict=True):
        needed = criterion.requires
        if verdict.share > 0 and needed is not None and not held(needed, criterion.requires_some):
            label = exercise.criteria[needed].label
            met = verdicts[needed].share > 0 if criterion.requires_some else verdicts[needed].held
            how = "did not count" if met else ("earned nothing" if criterion.requires_some else "did not hold")
            verdict = Verdict(False, f"{verdict.line}, but this counts only with {label}, which {how}")
        elif verdict.share > 0 and needed is not None and criterion.requires_some and verdicts[needed].share < 1:
            part = verdicts[needed].share  # a near miss: this counts as far as that one did
            label = exercise.criteria[needed].label
            line = f"{verdict.line}, counted at {part:.0%} as {label} was"
            verdict = Verdict(False, line, verdict.share * part)
        out.append(verdict)
    return out


def _address_space_mb() -> float | None:
    """How much address space this process holds (what its memory limit counts), MiB; None where unknown."""
    try:
        with open("/proc/self/statm", encoding="ascii") as statm:
            return int(statm.read().split()[0]) * resource.getpagesize() / 2**20
    except (OSError, ValueError, IndexError):
        return None


def _graded(
    exercise: Exercise,
    student: str,
    path: Path,
    allow_plugins: bool,
    memory_mb: int,
    cpu_s: float,
    traces: Path | None = None,
    feedback: Path | None = None,
    name: str = "",
    corrections: list[tuple[float, str]] | None = None,
) -> tuple[Report | str, bool]:
    """One submission's report, or why it could not be graded (this student's zero); and whether the worker ends.

    A submission that used up its CPU time gets its report of zero here, whatever became of the
    exception that told it (code that catches everything may have turned it into another, or
    kept it): it is not graded again.
    """
    _cpu.rung = 0
    started_cpu_s = cpu_time_s()
    result: Report | str
    runs: list[ReplayMaker] | None = None
    try:
        _cpu.armed = True
        cpu_alarm(cpu_s, again_s=CPU_GRACE_S)  # again, should a plugin's ``except BaseException`` keep it
        try:
            runs = [] if feedback is not None else None
            if traces is None and runs is None:
                result = grade_one(exercise, student, path, allow_plugins)
            else:
                result = grade_one(exercise, student, path, allow_plugins, traces=traces, runs=runs, name=name)
        finally:
            _cpu.armed = False  # first: a signal on its way now is let go
            cpu_alarm(None)
    except MemoryError:
        result = f"used more than {memory_mb} MiB of memory"
    except (CpuExhausted, Exception, SystemExit, KeyboardInterrupt) as err:  # noqa: BLE001 - this student's zero
        last = traceback.extract_tb(err.__traceback__)[-1:] if err.__traceback__ else []
        at = f" at {Path(last[0].filename).name}:{last[0].lineno}" if last else ""
        result = f"grading stopped with {type(err).__name__}: {err}{at}"
    if _cpu.rung:  # its runs are not replayed: the page says why it scores nothing
        zero = [0.0] * len(exercise.criteria)
        result, runs = Report(student, str(path), 0.0, exercise.max_points, zero, [_cpu_used_up_why(cpu_s)]), None
    ends = isinstance(result, str) or bool(_cpu.rung)
    if feedback is not None and isinstance(result, Report):  # in the worker: as many pages at once as workers
        _feedback_page(exercise, result, feedback, runs or [], name or file_names([student])[student], corrections)
    if isinstance(result, Report):
        result.cpu_s = cpu_time_s() - started_cpu_s
    return result, ends


def _feedback_page(
    exercise: Exercise,
    report: Report,
    folder: Path,
    runs: list[ReplayMaker],
    name: str,
    corrections: list[tuple[float, str]] | None,
) -> None:
    """Writes the student's feedback page, with the mark the gradebook will show (the teacher's corrections in it)."""
    from autonomy.classroom.report import write_feedback_page  # the reports' module builds on this one

    shown = report
    if corrections:
        extra = sum(points for points, _ in corrections)
        shown = replace(report, adjustments=list(corrections), total=round(report.total + extra, 2))
    try:
        write_feedback_page(exercise, shown, folder, runs, name)
    except (OSError, ValueError) as err:
        report.notes.append(f"its feedback page could not be written: {err}")


def _worker(
    exercise: Exercise,
    allow_plugins: bool,
    memory_mb: int,
    cpu_s: float,
    channel: Connection,
    traces: Path | None = None,
    feedback: Path | None = None,
    names: dict[str, str] | None = None,
    corrections: dict[str, list[tuple[float, str]]] | None = None,
    by_name: bool = False,
) -> None:
    """A worker process's body: limits its memory, then grades the submissions it is sent, one at a time.

    Each submission may use ``cpu_s`` of CPU time, counted by the kernel from where it starts.

    It leads a process group of its own, so that whatever a plugin starts goes with it. Each
    submission comes as (student, path) and goes back as (report or why not, whether the
    worker ends now). A worker grades one submission after another while nothing of them
    could have changed it: it ends after a submission whose grading failed, after any
    submission when plugins are allowed (a plugin's Python may change anything), and after
    one that left it holding more memory than it started with (``RETIRE_GROWTH_MB``). The
    next submission then gets a new worker.
    """
    os.setpgid(0, 0)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the grader ends its workers; a Ctrl-C is for the grader
    signal.signal(signal.SIGPROF, _on_cpu_limit)
    # What the worker was forked with (modules, the exercise) lives as long as it does: left out of
    # the garbage collector's passes, which the records of each seed would otherwise repeat over it
    # (and each pass would copy the pages it touches from the grader).
    gc.freeze()
    limit = memory_mb * 1024 * 1024
    try:
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    except (ValueError, OSError):
        pass
    started_mb = _address_space_mb()
    while True:
        try:
            job = channel.recv()
        except Exception:  # noqa: BLE001 - the grader gone, or no memory left to read with: this worker ends
            return
        if job is None:
            return
        student, path = job
        if by_name:  # graded from its own folder: the report, the page and the runs name the file alone
            os.chdir(path.parent)
            path = Path(path.name)
        Blackboard.clear()  # as a new worker has it: nothing of the last submission's trees
        if allow_plugins:  # what a plugin starts inherits it
            _cap_what_it_starts(cpu_s)
        report, failed = _graded(
            exercise,
            student,
            path,
            allow_plugins,
            memory_mb,
            cpu_s,
            traces,
            feedback,
            (names or {}).get(student, ""),
            (corrections or {}).get(student),
        )
        cpu_alarm(None)  # whatever happened in there, nothing goes off between submissions
        try:
            gc.collect()  # the last submission's trees (cycles of parents and children) let go now
            now_mb = _address_space_mb()
            grown = started_mb is None or now_mb is None or now_mb - started_mb > RETIRE_GROWTH_MB
        except MemoryError:  # no memory left even to look: the report still goes, and this worker ends
            grown = True
        last = allow_plugins or failed or grown
        try:
            channel.send((report, last))
        except (OSError, MemoryError, ValueError):
            os._exit(3)
        if last:
            channel.close()
            return


@dataclass
class _Running:
    """A worker process, the submission it grades (None while it waits for one), and whether it graded one before."""

    process: Any
    channel: Connection
    index: int | None = None
    deadline_s: float = 0.0
    used: bool = False


def grade_class(
    exercise: Exercise,
    submissions: list[tuple[str, Path]],
    *,
    workers: int | None = None,
    cpu_s: float = DEFAULT_CPU_S,
    wall_s: float | None = None,
    memory_mb: int = DEFAULT_MEMORY_MB,
    allow_plugins: bool = False,
    on_report: Callable[[Report], None] | None = None,
    traces: Path | None = None,
    feedback: Path | None = None,
    corrections: dict[str, list[tuple[float, str]]] | None = None,
    start_method: str = "fork",
    by_name: bool = False,
) -> list[Report]:
    """Grades every submission in worker processes, at most ``workers`` at once.

    A worker grades one submission after another (see :func:`_worker` for when it is replaced
    by a new one). A submission whose grading failed (or whose worker died) in a worker that
    had graded another before is graded again in a new worker, and that result stands: what
    a submission before left behind (memory, above all) never costs a student their marks, and
    the marks are those of a new worker for each, whatever the order or the number of
    workers. Each submission has ``cpu_s`` of CPU time, and ``wall_s`` of wall time for one that
    waits without working; one that takes longer costs that student a zero (not graded again: an
    endless loop would cost twice the time).

    Args:
        exercise: The exercise.
        submissions: (student, path) pairs, as :func:`find_submissions` gives them.
        workers: Processes at once (default: the machine's cores).
        cpu_s: CPU time a submission may take, all its seeds together.
        wall_s: Wall time a submission may take (default: ``WALL_PER_CPU`` times ``cpu_s``).
        memory_mb: Memory a worker process may take.
        allow_plugins: Whether submissions may load Python plugins.
        on_report: Called with each report as it is ready (for a progress bar).
        traces: A folder to keep each run's trace in (see :func:`trace_path`), for its replay.
        feedback: A folder to write each student's feedback page in (see :func:`page_path`), by the workers.
        corrections: The teacher's corrections by student, which their feedback pages show (the
            reports themselves do not get them: see :func:`autonomy.classroom.gradebook.apply_adjustments`).
        start_method: How workers start: ``fork`` (the grader is one thread), or ``forkserver`` for a
            process with threads of its own (a server), whose workers are forked from a clean process.
        by_name: Each submission is graded from its own folder, its file named by its name alone in
            the report, the page and the runs (a class's server: where it keeps the file is none of the
            student's business). The submissions are files.

    Returns:
        The reports, in the order of ``submissions``.
    """
    workers = max(1, workers or os.cpu_count() or 1)
    wall_s = WALL_PER_CPU * cpu_s if wall_s is None else wall_s
    if by_name:  # a worker grades from each file's folder: every other place is told whole
        submissions = [(student, path.resolve()) for student, path in submissions]
        traces, feedback = (None if f is None else f.resolve() for f in (traces, feedback))
    names = file_names(student for student, _ in submissions) if traces is not None or feedback is not None else {}
    context = multiprocessing.get_context(start_method)
    if start_method == "forkserver":  # its workers are forked with the grader's modules loaded, not each importing them
        context.set_forkserver_preload(["autonomy.classroom.grade"])
    clock = RealClock()
    reports: dict[int, Report] = {}
    pending = list(range(len(submissions)))
    pool: list[_Running] = []
    zero = [0.0] * len(exercise.criteria)

    def failed(index: int, why: str) -> Report:
        student, path = submissions[index]
        report = Report(student, path.name if by_name else str(path), 0.0, exercise.max_points, list(zero), [why])
        if feedback is not None:  # its worker made no page (it ran out of time, or ended): the page says why
            name = names.get(student) or file_names([student])[student]
            _feedback_page(exercise, report, feedback, [], name, (corrections or {}).get(student))
        return report

    def finish(index: int, report: Report) -> None:
        reports[index] = report
        if on_report is not None:
            on_report(report)

    def give(worker: _Running, index: int) -> None:
        worker.index, worker.deadline_s = index, clock.now() + wall_s
        try:
            worker.channel.send(submissions[index])
        except OSError:  # the worker is gone: reading from it says so, and the submission is graded again
            pass

    def end(worker: _Running) -> None:
        _kill_group(worker.process)  # first: whatever the submission started ends with it
        worker.process.join(5)
        worker.channel.close()
        if worker in pool:
            pool.remove(worker)

    def start(index: int) -> None:
        mine, theirs = context.Pipe(duplex=True)
        process = context.Process(
            target=_worker,
            args=(exercise, allow_plugins, memory_mb, cpu_s, theirs, traces, feedback, names, corrections, by_name),
            daemon=True,
        )
        process.start()
        theirs.close()
        worker = _Running(process, mine)
        pool.append(worker)
        give(worker, index)

    try:
        while pending or any(worker.index is not None for worker in pool):
            for worker in pool:
                if worker.index is None and pending:
                    give(worker, pending.pop(0))
            while pending and len(pool) < workers:
                start(pending.pop(0))
            busy = [worker for worker in pool if worker.index is not None]
            soonest = min(worker.deadline_s for worker in busy)
            ready = wait([worker.channel for worker in busy], timeout=max(0.0, soonest - clock.now()))
            for worker in busy:
                if worker.channel not in ready:
                    continue
                index = cast(int, worker.index)
                worker.index = None
                try:
                    result, last = worker.channel.recv()
                except (EOFError, OSError, ValueError, TypeError):
                    result, last = None, True
                if last or not isinstance(result, Report):
                    end(worker)
                if result is None and worker.process.exitcode in (CPU_EXIT_CODE, -signal.SIGXCPU):  # not graded again
                    finish(index, replace(failed(index, _cpu_used_up_why(cpu_s)), cpu_s=cpu_s))
                elif not isinstance(result, Report) and worker.used:
                    start(index)  # perhaps what came before was the cause: a new worker, in the place it left
                elif isinstance(result, Report):
                    finish(index, result)
                elif isinstance(result, str):
                    finish(index, failed(index, result))
                else:
                    why = f"the grading process ended without a report (exit code {worker.process.exitcode})"
                    finish(index, failed(index, why))
                worker.used = True
            now = clock.now()
            for worker in list(pool):
                if worker.index is not None and now >= worker.deadline_s:
                    index = worker.index
                    end(worker)
                    why = f"took more than {wall_s:g} s of wall time" + (
                        ", waiting rather than working (a plugin that sleeps?)" if wall_s >= cpu_s else ""
                    )
                    finish(index, failed(index, f"{why} (--wall-seconds gives more)"))
    finally:
        # a second Ctrl-C must not cut the clean-up short and leave workers behind
        blocked = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM, signal.SIGHUP})
        try:
            for worker in list(pool):
                end(worker)
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, blocked)
    return [reports[i] for i in range(len(submissions))]


def _kill_group(process: Any) -> None:
    """Ends a worker and every process in its group (what a plugin may have started)."""
    try:
        os.killpg(process.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):  # gone, or not yet leading its group
        pass
    try:
        process.kill()
    except (OSError, ValueError):
        pass


# ------------------------------------------------------------------------------------------ on a Dask cluster


def _bundle(path: Path) -> list[tuple[str, bytes]]:
    """A submission's files as they are given (a file, or a folder's own regular files), to send elsewhere."""
    if path.is_file() and not path.is_symlink():
        return [(path.name, path.read_bytes())]
    if path.is_dir():
        return [
            (item.name, item.read_bytes())
            for item in sorted(path.iterdir())
            if item.is_file() and not item.is_symlink() and item.stat().st_size <= 4 * 2**20
        ]
    return []  # missing, or a link: graded where it lands, which says so


def in_a_daemon() -> bool:
    """Whether this process is a daemon (a Dask worker by default): it may start subprocesses, not multiprocessing's."""
    return bool(multiprocessing.current_process().daemon)


def _dask_job(
    exercise: Exercise, jobs: list[tuple[str, str, list[tuple[str, bytes]], bool]], options: dict[str, Any]
) -> list[Report]:
    """The job of some submissions on a Dask worker: the same as a local worker's, in a limited process of their own.

    Each submission's files are put back in a folder of their own, under this job's, and the lot
    are graded there by :func:`grade_class` with one worker (which grades one after another as a
    local worker does, in a new process when anything of one could change the next); each report
    then names its files as they were given, so that its bytes are the same as a local grading's.
    Nothing of this changes the worker's own folder, which its other threads go on using.
    """
    import tempfile

    if in_a_daemon():  # graded in a process of its own, which may start the submissions' (see child.py)
        from autonomy.classroom.child import call_in_child

        return call_in_child(_dask_job, exercise, jobs, options)
    with tempfile.TemporaryDirectory(prefix="autonomy-grade-") as folder:
        places: list[Path] = []
        for index, (_, given, files, is_folder) in enumerate(jobs):
            place = Path(folder) / str(index) / (Path(given).name or "submission")
            if files and is_folder:
                place.mkdir(parents=True)
                for name, data in files:
                    (place / name).write_bytes(data)
            elif files:
                place.parent.mkdir(parents=True)
                place.write_bytes(files[0][1])
            places.append(place)
        reports = grade_class(
            exercise, [(job[0], place) for job, place in zip(jobs, places, strict=True)], workers=1, **options
        )
    for report, place, (_, given, _, _) in zip(reports, places, jobs, strict=True):
        # the folder it was put back in is no part of what the student sees: named as given, as here
        names = [(str(place), given)]
        if report.file and report.file != str(place) and report.file.startswith(str(place)):
            names.insert(0, (report.file, str(Path(given) / Path(report.file).relative_to(place))))
        for inside, shown in names:
            report.file = report.file.replace(inside, shown)
            report.problems = [problem.replace(inside, shown) for problem in report.problems]
    return reports


def grade_on_dask(
    exercise: Exercise,
    submissions: list[tuple[str, Path]],
    address: str,
    *,
    cpu_s: float = DEFAULT_CPU_S,
    wall_s: float | None = None,
    memory_mb: int = DEFAULT_MEMORY_MB,
    allow_plugins: bool = False,
    on_report: Callable[[Report], None] | None = None,
) -> list[Report]:
    """Grades every submission on the Dask cluster at ``address``: :func:`grade_class`'s job, another executor.

    The submissions go to the workers with their files, a few to a task (four tasks a worker
    thread, so that a slow one does not hold the rest back), and each task grades its own with
    :func:`grade_class` in a limited process, with the same limits as here: the marks are those
    of a local grading, byte for byte.

    Raises:
        ImportError: ``dask.distributed`` is not installed (``pip install 'autonomy[cluster]'``).
        OSError: no scheduler answers at ``address``.
    """
    from distributed import Client, as_completed

    options = {
        "cpu_s": cpu_s,
        "wall_s": WALL_PER_CPU * cpu_s if wall_s is None else wall_s,
        "memory_mb": memory_mb,
        "allow_plugins": allow_plugins,
    }
    with Client(address, timeout="5s") as client:
        threads = max(1, sum(client.nthreads().values()))
        size = max(1, math.ceil(len(submissions) / (4 * threads)))
        futures = {}
        for first in range(0, len(submissions), size):
            jobs = [
                (student, str(path), _bundle(path), path.is_dir())
                for student, path in submissions[first : first + size]
            ]
            task = client.submit(_dask_job, exercise, jobs, options, key=f"grade-{first}", pure=False)
            futures[task] = first
        reports: dict[int, Report] = {}
        for done in as_completed(futures):
            for offset, report in enumerate(done.result()):
                reports[futures[done] + offset] = report
                if on_report is not None:
                    on_report(report)
    return [reports[i] for i in range(len(submissions))]
