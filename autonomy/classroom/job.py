"""The job: one submission of one exercise graded in this process, on every seed, into its :class:`Report`.

It checks the mission without running any of its Python (plugins are refused unless the
teacher allows them), runs it on each seed in virtual time on the in-process emulator, judges
each run, and marks it: grading twice gives the same report, byte for byte. The executors
(:mod:`~autonomy.classroom.pool`, :mod:`~autonomy.classroom.cluster`, the live class's lanes)
run this job in limited processes; the outputs read its :class:`Report` alone.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any
from urllib.parse import urlencode

from autonomy.classroom.exercise import Exercise, Seed
from autonomy.classroom.facts import Gatherer, RunFacts, facts_of, path_points
from autonomy.classroom.judge import Verdict, judge
from autonomy.classroom.results import Report, SeedResult, file_names
from autonomy.classroom.submissions import mission_file, readable
from autonomy.classroom.told import named_node
from autonomy.client import Client
from autonomy.emulator.script import SensorScript
from autonomy.emulator.world import Pose
from autonomy.errors import LinkError
from autonomy.mission import MissionInvalid, MissionSpec, NodeSpec, Problem, validate_text
from autonomy.record import Record
from autonomy.runner import Runner
from autonomy.source import UnreadableFile, read_text
from autonomy.trace import TraceWriter
from autonomy.views.page import ReplayMaker

#: Why a submission's plugins are refused (YAML's ``plugins:`` or XML's ``_plugins``): nothing of them is imported.
PLUGINS_REFUSED = (
    "Python plugins are not run when grading unless the teacher allows them (autonomy grade --allow-plugins)"
)


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
    text, why = read_mission(path)
    if text is None:
        return None, [why]
    spec, problems = check_text(exercise, text, str(path), path.parent, allow_plugins)
    return spec, [str(p) for p in problems]


def read_mission(path: Path) -> tuple[str | None, str]:
    """A mission file's text, as every mission file is read; or None and why not (``FILE:LINE:COL: ...``)."""
    if path.is_symlink():
        return None, f"{path}:1:1: a link, not a file: hand in the mission file itself"
    try:
        return read_text(path), ""
    except UnreadableFile as err:
        return None, f"{path}:{err.line}:{err.column}: cannot read the file: {err.reason}"


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


def seed_url(exercise: Exercise, seed: Seed, virtual: bool = True, more: dict[str, object] | None = None) -> str:
    """The ``emu://`` address a seed of the exercise is run on: its world, its robot, the seed, its noise and faults.

    ``more`` are further emulator options (``battery``), as ``emu://`` takes them.
    """
    options: dict[str, object] = {"world": exercise.world_ref, "seed": seed.seed}
    options |= {"time": "virtual"} if virtual else {}
    options |= {"noise": seed.noise_mm} | ({"faults": seed.faults} if seed.faults else {}) | (more or {})
    options |= {"profile": exercise.robot_ref} if exercise.robot_ref else {}
    # a world file's path may hold bytes that are not UTF-8: they go through the URL as they are
    return "emu://?" + urlencode(options, errors="surrogateescape")


def run_seed(
    exercise: Exercise,
    spec: MissionSpec,
    seed: Seed,
    trace: Path | None = None,
    replay: ReplayMaker | None = None,
    watchers: Sequence[Callable[[Record], None]] = (),
    emulator: dict[str, object] | None = None,
    script: SensorScript | None = None,
    start: Pose | None = None,
) -> RunFacts:
    """Runs ``spec`` once on ``seed`` in the exercise's world, in virtual time; returns its facts.

    The facts are gathered as the records come, and the records let go: a long run is not
    held in memory (nor gone over again and again by the garbage collector). With ``trace``,
    the run is also written there as a trace, and with ``replay`` made into a page's replay (nodes'
    states included, either way); each of ``watchers`` is given every record too, the nodes' states
    in them. ``emulator`` holds further emulator options (``battery``: see :func:`seed_url`), and
    ``script`` what the robot's sensors report from the run's start on, whatever its world holds;
    ``start``, where the robot starts instead of the world's start.
    """
    client = Client.open(seed_url(exercise, seed, more=emulator))
    if start is not None:
        client.port.emulator.robot.place(start)  # type: ignore[attr-defined]  # an emu:// link's port has its emulator
    if script is not None:
        robot = client.port.emulator.robot  # type: ignore[attr-defined]  # an emu:// link's port has its emulator
        robot.script, robot.script_from_s = script, client.clock.now()  # the model is brought to the clock's time
    gatherer = Gatherer()
    stream = trace.open("w", encoding="utf-8") if trace is not None else None
    try:
        listeners: list[Any] = [gatherer] + ([TraceWriter(stream)] if stream is not None else [])
        listeners += ([replay] if replay is not None else []) + list(watchers)
        replayed = stream is not None or replay is not None or bool(watchers)
        runner = Runner.for_mission(
            spec, client, max_seconds=exercise.time_limit_s, listeners=listeners, node_states=replayed, tips=True
        )  # the judge reads the emulator's own account: the nodes' states are looked for only for a replay
        runner.run()
        robot = client.port.emulator.robot  # type: ignore[attr-defined]  # an emu:// link's port has its emulator
        left_going = bool(robot.target_speed_mm_s or robot.turn_remaining_deg)  # as the run left it, before it settles
        facts = facts_of(gatherer, robot, exercise.time_limit_s, runner.tips or [])
        facts.left_going = left_going
        return facts
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
        [(*at(c.time_s, c.pose.x_mm, c.pose.y_mm), round(c.speed_mm_s)) for c in facts.collisions],
        [at(b.time_s, b.pose.x_mm, b.pose.y_mm) for b in facts.sounded],
        [(*at(turn.time_s, turn.x_mm, turn.y_mm), round(turn.degrees, 1)) for turn in facts.turns],
        None if facts.rest_s is None else round(facts.rest_s, 2),
        seed.seed,
        trace,
        [_lost_while(facts, v) for v in verdicts],
    )


def _lost_while(facts: RunFacts, verdict: Verdict) -> str:
    """The type of the node running when ``verdict``'s criterion was lost, as its line says; empty: held, or none."""
    node = named_node(facts, verdict.line) if verdict.share < 1.0 else None
    return facts.node_kinds[node] if node is not None and node < len(facts.node_kinds) else ""


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
    """Grades one submission as it was handed in (a file, or a folder of the student's files), in this process.

    Its mission file is found and read (:func:`check_submission` says why not), then graded by
    :func:`grade_mission`, with the same ``traces``, ``runs`` and ``name``.
    """
    zero = [0.0] * len(exercise.criteria)
    mission, why = mission_file(path)
    if mission is None:
        return Report(student, "", 0.0, exercise.max_points, zero, [why])
    text, why = read_mission(mission)
    if text is None:
        return Report(student, readable(str(mission)), 0.0, exercise.max_points, zero, [why])
    return grade_mission(exercise, student, text, str(mission), mission.parent, allow_plugins, traces, runs, name)


def grade_mission(
    exercise: Exercise,
    student: str,
    text: str,
    label: str,
    base_dir: Path,
    allow_plugins: bool = False,
    traces: Path | None = None,
    runs: list[ReplayMaker] | None = None,
    name: str = "",
) -> Report:
    """The job: a mission's text graded on every seed of the exercise (in this process), into its report.

    Args:
        exercise: The exercise, with its hidden seeds when they are to be graded.
        student: Who it is from.
        text: The mission file's text.
        label: How the file is named in its problems and its report.
        base_dir: Where its plugins would be (refused unless ``allow_plugins``).
        allow_plugins: Whether it may load Python plugins.
        traces: A folder to keep each run's trace in (under ``name``, the student's as a file's).
        runs: Each seed's run is added to this list as its replay, for a page.
        name: The student as a file's name (default: :func:`file_names`'s).
    """
    zero = [0.0] * len(exercise.criteria)
    spec, problems = check_text(exercise, text, label, base_dir, allow_plugins)
    if spec is None:
        return Report(student, readable(label), 0.0, exercise.max_points, zero, [str(p) for p in problems])
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
        verdicts = verdicts_of(exercise, seed, facts)
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
    report = Report(student, readable(label), total, exercise.max_points, marks, [], seeds, notes)
    report.shape = list(tree_shape(spec))
    return report


def verdicts_of(exercise: Exercise, seed: Seed, facts: RunFacts) -> list[Verdict]:
    """Each criterion's verdict on one run of a seed, judged in that seed's world, requirements applied."""
    world = exercise.world.for_seed(seed.seed)  # where this seed put what the world varies
    return _with_requirements(exercise, [judge(c, facts, world) for c in exercise.criteria])


def _with_requirements(exercise: Exercise, verdicts: list[Verdict]) -> list[Verdict]:
    """Each criterion that requires another earns, on each seed, the part of its own that that one earned there.

    Where that one earned nothing (or, with ``requires_all``, did not hold in full), this one earns nothing;
    what that one requires counts the same way, down the chain.
    """

    def part(index: int) -> float:
        """The part of its points ``index`` earned, as what it requires let it."""
        criterion = exercise.criteria[index]
        share = verdicts[index].share
        if criterion.requires is None:
            return share
        needed = part(criterion.requires)
        return share * needed if not criterion.requires_all else share if needed >= 1.0 else 0.0

    out = []
    for criterion, verdict in zip(exercise.criteria, verdicts, strict=True):
        needed = criterion.requires
        if verdict.share <= 0 or needed is None:
            out.append(verdict)
            continue
        label, got = exercise.criteria[needed].shown, part(needed)
        if got <= 0 or (criterion.requires_all and got < 1.0):
            met = verdicts[needed].held if criterion.requires_all else verdicts[needed].share > 0
            how = "did not count" if met else ("did not hold" if criterion.requires_all else "earned nothing")
            verdict = Verdict(False, f"{verdict.line}, but this counts only with {label}, which {how}")
        elif got < 1.0 and not criterion.requires_all:  # a near miss: this counts as far as that one did
            verdict = Verdict(False, f"{verdict.line}, counted at {got:.0%} as {label} was", verdict.share * got)
        out.append(verdict)
    return out
