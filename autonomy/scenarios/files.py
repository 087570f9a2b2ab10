"""Scenario files: a mission's tests, beside it, in the words of the exercises (docs/testing.md).

A scenario file is ``NAME.test.yaml`` beside the mission ``NAME.yaml``::

    scenarios:
      - name: parks in the garage
        world: garage
        seeds: [1, 2, 3]
        time_limit_s: 30
        expect:
          outcome: succeeded
          within_s: 20
          criteria:
            - rest_in_zone: garage
            - max_collisions: 0
        nodes:
          - node: to the end
            reaches: SUCCESS
            before_s: 15
          - node: back off
            runs: false

Each scenario runs the mission once on each of its seeds, in virtual time, and holds when every
seed meets all it expects. It is read as a mission or an exercise is: every problem at once, as
``FILE:LINE:COL``, with a did-you-mean; a node it names must be in the mission's tree.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TypeVar

from autonomy.behaviours.tree import describe_tree
from autonomy.classroom.exercise import MAX_TIME_LIMIT_S, Exercise, ExerciseInvalid, ExerciseReader, Seed
from autonomy.emulator.script import REFUSABLE, Area, SensorScript
from autonomy.emulator.world import ROBOT_RADIUS_MM, Pose, World, read_shape
from autonomy.mission import MissionInvalid, MissionSpec, build_tree, load_mission
from autonomy.record import NodeInfo
from autonomy.runner import CRASHED, FAILED, INTERRUPTED, LINK_LOST, SUCCEEDED, TIME_LIMIT
from autonomy.source import Located, Problem, UnreadableFile, parse, read_text, suggest

T = TypeVar("T")
#: What a scenario file ends in; the mission it tests is the same name without ``.test``.
SUFFIX = ".test.yaml"
TOP_LEVEL = ("mission", "scenarios")
SCENARIO_KEYS = ("name", "world", "seeds", "start", "time_limit_s", "battery", "sensors", "expect", "nodes")
START_KEYS = ("x_mm", "y_mm", "heading_deg")
SENSOR_KEYS = ("front_mm", "bumps_s", "tilt_deg", "refuses", "where")
AREA_KEYS = ("zone", "box", "circle", "heading_deg", "front_mm", "bump", "tilt_deg")
EXPECT_KEYS = ("outcome", "within_s", "criteria", "beeps", "distance_mm", "servos")
BEEP_KEYS = ("count", "volume")
SERVO_KEYS = ("id", "angles")
NODE_KEYS = ("node", "reaches", "before_s", "never", "after_s", "runs")
#: The outcomes a run may end with, as ``autonomy run`` says them.
OUTCOMES = (SUCCEEDED, FAILED, TIME_LIMIT, LINK_LOST, CRASHED, INTERRUPTED)
#: The statuses a node's check may name (py_trees' own words).
STATUSES = ("SUCCESS", "FAILURE", "RUNNING")
#: A scenario's time limit when it sets none, simulated seconds.
DEFAULT_TIME_LIMIT_S = 60.0
MAX_SCENARIOS = 200
#: The largest mission file looked into for a ``tests:`` list when a folder is searched (a mission is smaller).
MAX_TESTS_FILE_BYTES = 1_000_000


@dataclass(frozen=True)
class NodeCheck:
    """What one node must do in a scenario's runs.

    Attributes:
        node: The node as the file names it: its name, its path of names from the root (``root/avoid``),
            or its type (every node of that type).
        ids: The ids of the tree's nodes it names.
        kind: ``reaches`` (the node returns ``status``, before ``time_s`` if set, at ``from_s`` or after
            if set), ``never`` (the node is never ``status`` after ``time_s``, 0 if not set) or ``runs``
            (the node is ticked at all, or, when ``expected`` is False, never).
        status: The status it is about (``SUCCESS``, ``FAILURE``, ``RUNNING``); empty for ``runs``.
        time_s: ``before_s`` or ``after_s``, simulated seconds from the start; None: not set.
        expected: For ``runs``: whether it must run (True) or must not (False).
        line: Where the check stands in the file.
        from_s: For ``reaches``: its ``after_s``, the time from which the status counts (None: from the start).
    """

    node: str
    ids: tuple[int, ...]
    kind: str
    status: str = ""
    time_s: float | None = None
    expected: bool = True
    line: int = 0
    from_s: float | None = None

    @property
    def words(self) -> str:
        """What it asks, in a few words: ``'to the end' reaches SUCCESS before 15 s``."""
        if self.kind == "runs":
            return f"'{self.node}' {'runs' if self.expected else 'never runs'}"
        if self.kind == "reaches":
            after = f" after {self.from_s:g} s" if self.from_s is not None else ""
            before = f" before {self.time_s:g} s" if self.time_s is not None else ""
            return f"'{self.node}' reaches {self.status}{after}{before}"
        return f"'{self.node}' is never {self.status}" + (f" after {self.time_s:g} s" if self.time_s else "")


@dataclass
class Scenario:
    """One scenario: where the mission runs, and what must hold on each of its seeds.

    Attributes:
        name: What the scenario is called.
        line: Where it starts in its file.
        exercise: Its world, seeds, time limit and criteria, as an exercise holds them (each criterion
            must hold in full on every seed).
        outcomes: The outcomes the run may end with (empty: any).
        within_s: When the mission must have ended by, simulated seconds (None: any time within the limit).
        nodes: What its nodes must do.
        battery: The battery's level at the start, 0..255 (None: the emulator's, 230).
        script: What the sensors report, by time, whatever the world holds (None: what it holds).
        beeps: How many beeps that make a sound (volume 1 or more) the run has, exactly (None: any).
        beep_volume: The volume each of them must have (None: any).
        distance_mm: The least and the most the robot may drive in all, forward and back (None: any).
        servos: For each servo it names, every angle it was sent to, in order, whole degrees.
        start: Where the robot starts (None: at its world's start, moved by the world's jitter).
    """

    name: str
    line: int
    exercise: Exercise
    outcomes: tuple[str, ...] = ()
    within_s: float | None = None
    nodes: list[NodeCheck] = field(default_factory=list)
    battery: int | None = None
    script: SensorScript | None = None
    beeps: int | None = None
    beep_volume: int | None = None
    distance_mm: tuple[float, float] | None = None
    servos: tuple[tuple[int, tuple[int, ...]], ...] = ()
    start: Pose | None = None


@dataclass
class ScenarioFile:
    """A read scenario file: the mission it tests, its tree, and its scenarios.

    Attributes:
        path: The scenario file.
        mission: The mission file it tests.
        spec: The mission, validated (its plugins loaded, as ``autonomy run`` loads them).
        nodes: The mission's tree, as a run's header describes it.
        scenarios: Its scenarios, in the file's order.
        statuses: By the type of each of its nodes, the statuses a node of it can return.
    """

    @property
    def paths(self) -> list[str]:
        """Each node's path of names from the root, by id."""
        return node_paths(self.nodes)

    path: Path
    mission: Path
    spec: MissionSpec
    nodes: list[NodeInfo]
    scenarios: list[Scenario]
    statuses: dict[str, tuple[str, ...]] = field(default_factory=dict)


class ScenariosInvalid(ExerciseInvalid):
    """A scenario file with problems (its mission's too); :attr:`problems` lists every one."""


def mission_of(path: Path) -> Path:
    """The mission a scenario file tests when it names none: ``NAME.yaml`` beside ``NAME.test.yaml``."""
    name = path.name[: -len(SUFFIX)] if path.name.endswith(SUFFIX) else path.stem
    return path.with_name(name + ".yaml")


def mission_of_test(path: Path) -> Path:
    """Where the scenarios of the mission ``path`` go: ``NAME.test.yaml`` beside ``NAME.yaml``."""
    return path.with_name(path.stem + SUFFIX)


def node_paths(nodes: list[NodeInfo]) -> list[str]:
    """Each node's path of names from the root, by id (``root/avoid/back off``)."""
    paths: list[str] = []
    for node in nodes:  # parents come before their children
        paths.append(node.name if node.parent is None else f"{paths[node.parent]}/{node.name}")
    return paths


def named(nodes: list[NodeInfo], node: str) -> tuple[int, ...]:
    """The ids of the nodes ``node`` names: by name, else by type; or by a path.

    A path (``wander for a minute/avoid``) is the node's own name last, and names of its ancestors before
    it, in order (not every one of them).
    """
    by_name = tuple(n.id for n in nodes if n.name == node)
    if by_name or "/" not in node:
        return by_name or tuple(n.id for n in nodes if n.type == node)
    wanted = node.split("/")
    return tuple(n.id for n in nodes if _along(_names_to(nodes, n.id), wanted))


def _names_to(nodes: list[NodeInfo], node: int) -> list[str]:
    """The names from the root down to ``node``, itself last."""
    names = []
    at: int | None = node
    while at is not None:
        names.append(nodes[at].name)
        at = nodes[at].parent
    return names[::-1]


def _along(names: list[str], wanted: list[str]) -> bool:
    """Whether ``wanted`` names the node ``names`` leads to: its own name last, its ancestors' before it, in order."""
    if not names or names[-1] != wanted[-1]:
        return False
    ancestors = iter(names[:-1])
    return all(any(name == want for name in ancestors) for want in wanted[:-1])


class _Reader(ExerciseReader):
    kind = "scenario file"
    #: Where the scenarios are: ``scenarios`` in a scenario file, ``tests`` in a mission.
    key = "scenarios"

    def file(self, root: Located, path: Path) -> tuple[Path | None, list[Located]]:
        """The mission's path and the scenarios' items, their problems noted."""
        if not isinstance(root.value, dict):
            self.problem(root, "", "a scenario file is a mapping with scenarios: (a list), and mission: if it is not "
                         f"{mission_of(path).name}")  # fmt: skip
            return None, []
        doc: dict[str, Located] = root.value
        mission: Path | None = path
        if "tree" in doc and "scenarios" not in doc:  # a mission: its own tests: list, or given for its tests
            if "tests" not in doc:
                self.problem(root, "", f"this is a mission, not its tests: they go in {mission_of_test(path).name} "
                             "beside it, or in a tests: list in it")  # fmt: skip
                return None, []
            self.key = "tests"
            items = doc["tests"]
        else:
            self.known_keys(root, "", TOP_LEVEL)
            mission = mission_of(path)
            if "mission" in doc:
                name = self.text(doc["mission"], "mission")
                mission = (self.base_dir / name) if name is not None else None
            items = doc.get("scenarios")  # type: ignore[assignment]
            if items is None:
                self.problem(root, "", "'scenarios' is missing: a list of scenarios, each with name: and world:")
                return mission, []
        if not isinstance(items.value, list) or not items.value:
            self.problem(items, self.key, "expected a list of scenarios, each with name: and world:")
            return mission, []
        if len(items.value) > MAX_SCENARIOS:
            self.problem(items, self.key, f"at most {MAX_SCENARIOS} scenarios in a file")
            return mission, []
        return mission, items.value

    def mappings(
        self, located: Located, where: str, why: str, allowed: tuple[str, ...]
    ) -> Iterator[tuple[str, Located, dict[str, Located]]]:
        """Each mapping of the list ``located``: its place (``where[k]``), itself and its keys, unknown ones noted.

        A list that is not one, or is empty, and an item that is not a mapping, are noted with ``why``.
        """
        if not isinstance(located.value, list) or not located.value:
            self.problem(located, where, why)
            return
        for k, item in enumerate(located.value):
            if not isinstance(item.value, dict):
                self.problem(item, f"{where}[{k}]", why)
                continue
            self.known_keys(item, f"{where}[{k}]", allowed)
            yield f"{where}[{k}]", item, item.value

    def known_keys(self, located: Located, where: str, allowed: tuple[str, ...]) -> None:
        """Notes each key of the mapping ``located`` that is not one of ``allowed``, with a did-you-mean."""
        for key in located.value:
            if key not in allowed:
                path = f"{where}.{key}" if where else key
                self.problem(located.keys[key], path, f"unknown key '{key}'{suggest(key, list(allowed))}")

    def scenario(self, item: Located, where: str, nodes: list[NodeInfo], names: set[str]) -> Scenario | None:
        """One scenario (None: its problems noted)."""
        start = len(self.problems)
        if not isinstance(item.value, dict):
            self.problem(item, where, "a scenario is a mapping: name:, world:, and what it expects (expect:, nodes:)")
            return None
        doc: dict[str, Located] = item.value
        self.known_keys(item, where, SCENARIO_KEYS)
        for key in ("name", "world"):
            if key not in doc:
                self.problem(item, where, f"'{key}' is missing")
        name = self.text(doc["name"], f"{where}.name") if "name" in doc else None
        if name is not None and name in names:
            self.problem(doc["name"], f"{where}.name", f"another scenario is named '{name}': each is told by its name")
        names.add(name or "")
        world, world_ref = self.world(doc["world"], f"{where}.world") if "world" in doc else (None, "")
        seeds = self.prefixed(f"{where}.", lambda: self.seeds(doc["seeds"])) if "seeds" in doc else [Seed(1)]
        limit = DEFAULT_TIME_LIMIT_S
        if "time_limit_s" in doc:
            limit = self.number(doc["time_limit_s"], f"{where}.time_limit_s", 0.1, MAX_TIME_LIMIT_S)
        outcomes, within_s, criteria, measures = (
            self.expect(doc["expect"], f"{where}.expect", world) if "expect" in doc else ((), None, [], {})
        )
        checks = self.nodes(doc["nodes"], f"{where}.nodes", nodes) if "nodes" in doc else []
        checked = outcomes or within_s is not None or criteria or checks or measures
        if "expect" not in doc and "nodes" not in doc or not checked:
            if len(self.problems) == start or "expect" not in doc and "nodes" not in doc:  # said once
                self.problem(item, where, "a scenario checks something: expect: (outcome, within_s, criteria, beeps, "
                             "distance_mm, servos), nodes:, or both")  # fmt: skip
        battery = self.number(doc["battery"], f"{where}.battery", 0, 255, whole=True) if "battery" in doc else None
        script = self.sensors(doc["sensors"], f"{where}.sensors", world) if "sensors" in doc else None
        start = self.start(doc["start"], f"{where}.start", world) if "start" in doc and world is not None else None
        if name is None or world is None or limit is None:
            return None
        exercise = Exercise(name, name, "", world, world_ref, float(limit), seeds, None, criteria, self.label)
        battery = None if battery is None else int(battery)
        return Scenario(name, item.line, exercise, outcomes, within_s, checks, battery, script, start=start, **measures)

    def start(self, located: Located, where: str, world: World) -> Pose | None:
        """``{x_mm, y_mm, heading_deg}``: where the robot starts, clear of the world's walls and obstacles."""
        why = "start: is a mapping of x_mm, y_mm and heading_deg, e.g. {x_mm: 500, y_mm: 500, heading_deg: 90}"
        if not isinstance(located.value, dict):
            self.problem(located, where, why)
            return None
        doc: dict[str, Located] = located.value
        self.known_keys(located, where, START_KEYS)
        missing = [key for key in ("x_mm", "y_mm") if key not in doc]
        if missing:
            self.problem(located, where, f"'{missing[0]}' is missing: {why}")
            return None
        x = self.number(doc["x_mm"], f"{where}.x_mm", 0.0, world.width_mm)
        y = self.number(doc["y_mm"], f"{where}.y_mm", 0.0, world.height_mm)
        heading = self.number(doc["heading_deg"], f"{where}.heading_deg", -360.0, 360.0) if "heading_deg" in doc else 0
        if x is None or y is None or heading is None:
            return None
        if world.clearance(x, y) < ROBOT_RADIUS_MM:
            self.problem(located, where, f"the robot (radius {ROBOT_RADIUS_MM:g} mm) at ({x:g}, {y:g}) would touch a "
                         f"wall or an obstacle of the world '{world.name}': start it further away")  # fmt: skip
            return None
        return Pose(float(x), float(y), float(heading))

    def prefixed(self, prefix: str, read: Callable[[], T]) -> T:
        """What ``read`` reads, each problem it notes said at its place in the scenario (``scenarios[0].seeds``)."""
        before = len(self.problems)
        value = read()
        self.problems[before:] = [replace(p, path=prefix + p.path) for p in self.problems[before:]]
        return value

    def sensors(self, located: Located, where: str, world: World | None) -> SensorScript | None:
        """What the sensors report, and what the robot refuses, by time.

        ``front_mm`` and ``tilt_deg`` are ``[[from_s, value], ...]``, ``bumps_s`` a list of times, and
        ``refuses`` the commands the robot answers NO from a time on (``{move: 12.5}``), and ``where``
        what they report by where the robot is (``[{zone: garage, front_mm: 80}]``).
        """
        if not isinstance(located.value, dict) or not located.value:
            self.problem(located, where, "sensors: is a mapping, e.g. {front_mm: [[0, 255], [2.5, 80]], bumps_s: [3]}")
            return None
        doc: dict[str, Located] = located.value
        self.known_keys(located, where, SENSOR_KEYS)
        front = self.steps(doc["front_mm"], f"{where}.front_mm", 0, 255) if "front_mm" in doc else ()
        tilt = self.steps(doc["tilt_deg"], f"{where}.tilt_deg", -127, 127) if "tilt_deg" in doc else ()
        bumps: list[float] = []
        if "bumps_s" in doc:
            given = doc["bumps_s"]
            if not isinstance(given.value, list) or not given.value:
                self.problem(given, f"{where}.bumps_s", "bumps_s: is a list of times, e.g. [3, 7.5]")
            else:
                for k, value in enumerate(given.value):
                    time_s = self.number(value, f"{where}.bumps_s[{k}]", 0, MAX_TIME_LIMIT_S)
                    if time_s is not None:
                        bumps.append(float(time_s))
        refuses = self.refusals(doc["refuses"], f"{where}.refuses") if "refuses" in doc else ()
        areas = self.areas(doc["where"], f"{where}.where", world) if "where" in doc else ()
        return SensorScript(front or (), tuple(sorted(bumps)), tilt or (), refuses, areas)

    def areas(self, located: Located, where: str, world: World | None) -> tuple[Area, ...]:
        """``[{zone: NAME or box: / circle:, front_mm / bump / tilt_deg, heading_deg: [FROM, TO]}, ...]``."""
        why = ("where: is a list of areas and what the sensors report in each, e.g. "
               "[{box: {from_mm: [1500, 0], to_mm: [2000, 2000]}, front_mm: 80}]")  # fmt: skip
        areas = []
        for at, item, doc in self.mappings(located, where, why, AREA_KEYS):
            places = [key for key in ("zone", "box", "circle") if key in doc]
            if len(places) != 1:
                self.problem(item, at, "an area is one of zone: (a zone of the world), box: or circle: (as a world's)")
                continue
            shape = None
            if places[0] == "zone":
                name = self.text(doc["zone"], f"{at}.zone")
                zone = world.zone(name) if world is not None and name is not None else None
                if name is not None and world is not None and zone is None:
                    names = [z.name for z in world.zones]
                    has = f": it has {', '.join(names)}" if names else ": it has none"
                    why = f"no zone named '{name}' in the world '{world.name}'{suggest(name, names)}{has}"
                    self.problem(doc["zone"], f"{at}.zone", why)
                shape = zone.shape if zone is not None else None
            else:
                given = item.value[places[0]]
                shape, problems = read_shape(
                    Located({places[0]: given}, given.line, given.column, {places[0]: item.keys[places[0]]}),
                    at,
                    self.label,
                )
                self.problems += problems
            said = [key for key in ("front_mm", "bump", "tilt_deg") if key in doc]
            if not said:
                self.problem(item, at, "an area says what the sensors report there: front_mm:, bump: true or tilt_deg:")
                continue
            front = self.number(doc["front_mm"], f"{at}.front_mm", 0, 255, whole=True) if "front_mm" in doc else None
            tilt = self.number(doc["tilt_deg"], f"{at}.tilt_deg", -127, 127, whole=True) if "tilt_deg" in doc else None
            bump = False
            if "bump" in doc:
                bump = doc["bump"].value is True
                if not isinstance(doc["bump"].value, bool):
                    self.problem(doc["bump"], f"{at}.bump", "bump: is true (the collision flag is up there) or false")
            heading = None
            if "heading_deg" in doc:
                given = doc["heading_deg"]
                if not isinstance(given.value, list) or len(given.value) != 2:
                    self.problem(given, f"{at}.heading_deg", "heading_deg: is [FROM, TO], the arc counter-clockwise "
                                 "from FROM to TO it faces in, e.g. [-45, 45] for east")  # fmt: skip
                else:
                    ends = [self.number(v, f"{at}.heading_deg[{j}]", -360, 360) for j, v in enumerate(given.value)]
                    heading = (float(ends[0]), float(ends[1])) if None not in ends else None
            if shape is not None:
                areas.append(Area(shape, heading, None if front is None else int(front), bump,
                                  None if tilt is None else int(tilt)))  # fmt: skip
        return tuple(areas)

    def refusals(self, located: Located, where: str) -> tuple[tuple[str, float], ...]:
        """``{command: from_s, ...}``: from that time on, the robot answers NO to that command."""
        why = (
            f"refuses: maps commands to the time they are refused from, e.g. {{move: 12.5}} (of {', '.join(REFUSABLE)})"
        )
        if not isinstance(located.value, dict) or not located.value:
            self.problem(located, where, why)
            return ()
        refusals = []
        for command, value in located.value.items():
            if command == "stop":
                self.problem(located.keys[command], f"{where}.stop", "a stop is never refused: the run's end stops the "
                             f"robot whatever a scenario says (refuses: takes {', '.join(REFUSABLE)})")  # fmt: skip
                continue
            if command not in REFUSABLE:
                self.problem(located.keys[command], f"{where}.{command}",
                             f"unknown command '{command}'{suggest(str(command), list(REFUSABLE))}: {why}")  # fmt: skip
                continue
            from_s = self.number(value, f"{where}.{command}", 0, MAX_TIME_LIMIT_S)
            if from_s is not None:
                refusals.append((str(command), float(from_s)))
        return tuple(refusals)

    def steps(self, located: Located, where: str, low: int, high: int) -> tuple[tuple[float, int], ...] | None:
        """``[[from_s, value], ...]``: from each time on, the value; in time order."""
        why = f"expected a list of [from_s, value] pairs, e.g. [[0, 255], [2.5, 80]] (value {low} to {high})"
        if not isinstance(located.value, list) or not located.value:
            self.problem(located, where, why)
            return None
        steps: list[tuple[float, int]] = []
        for k, item in enumerate(located.value):
            if not isinstance(item.value, list) or len(item.value) != 2:
                self.problem(item, f"{where}[{k}]", why)
                continue
            time_s = self.number(item.value[0], f"{where}[{k}][0]", 0, MAX_TIME_LIMIT_S)
            value = self.number(item.value[1], f"{where}[{k}][1]", low, high, whole=True)
            if time_s is not None and value is not None:
                if steps and time_s <= steps[-1][0]:
                    self.problem(item, f"{where}[{k}]", f"the times go up: {time_s:g} s comes after {steps[-1][0]:g} s")
                steps.append((float(time_s), int(value)))
        return tuple(steps)

    def expect(
        self, located: Located, where: str, world: object
    ) -> tuple[tuple[str, ...], float | None, list, dict[str, object]]:
        """The outcomes, the time, the criteria and the measures (``beeps``...: Scenario's fields) it expects."""
        if not isinstance(located.value, dict):
            self.problem(located, where, f"expect: is a mapping of {', '.join(EXPECT_KEYS)}")
            return (), None, [], {}
        doc: dict[str, Located] = located.value
        self.known_keys(located, where, EXPECT_KEYS)
        outcomes: list[str] = []
        if "outcome" in doc:
            given = doc["outcome"].value if isinstance(doc["outcome"].value, list) else [doc["outcome"]]
            for value in given:
                text = self.text(value, f"{where}.outcome")
                if text is not None and text not in OUTCOMES:
                    self.problem(value, f"{where}.outcome", f"unknown outcome '{text}'{suggest(text, list(OUTCOMES))}: "
                                 f"one of {', '.join(OUTCOMES)}")  # fmt: skip
                elif text is not None:
                    outcomes.append(text)
        within_s = (
            self.number(doc["within_s"], f"{where}.within_s", 0.0, MAX_TIME_LIMIT_S) if "within_s" in doc else None
        )
        criteria = (
            self.prefixed(f"{where}.", lambda: self.criteria(doc["criteria"], world)) if "criteria" in doc else []  # type: ignore[arg-type]
        )
        measures: dict[str, object] = {}
        if "beeps" in doc:
            measures.update(self.beeps(doc["beeps"], f"{where}.beeps"))
        if "distance_mm" in doc:
            span = self.span(doc["distance_mm"], f"{where}.distance_mm")
            if span is not None:
                measures["distance_mm"] = span
        if "servos" in doc:
            servos = self.servos(doc["servos"], f"{where}.servos")
            if servos:
                measures["servos"] = servos
        return tuple(outcomes), within_s, criteria, measures

    def beeps(self, located: Located, where: str) -> dict[str, int]:
        """``beeps: N`` or ``{count: N, volume: V}``: how many beeps that make a sound, and how loud each is."""
        if not isinstance(located.value, dict):
            count = self.number(located, where, 0, 10_000, whole=True)
            return {} if count is None else {"beeps": int(count)}
        doc: dict[str, Located] = located.value
        self.known_keys(located, where, BEEP_KEYS)
        if "count" not in doc:
            self.problem(
                located, where, "'count' is missing: how many beeps that make a sound, e.g. {count: 2, volume: 4}"
            )
            return {}
        count = self.number(doc["count"], f"{where}.count", 0, 10_000, whole=True)
        volume = self.number(doc["volume"], f"{where}.volume", 1, 5, whole=True) if "volume" in doc else None
        found = {} if count is None else {"beeps": int(count)}
        return found | ({"beep_volume": int(volume)} if volume is not None else {})

    def span(self, located: Located, where: str) -> tuple[float, float] | None:
        """``[LOW, HIGH]``, millimetres, LOW no more than HIGH."""
        if not isinstance(located.value, list) or len(located.value) != 2:
            self.problem(located, where, "expected [LOW, HIGH] in mm, e.g. [1150, 1250]")
            return None
        low, high = (self.number(v, f"{where}[{k}]", 0, 1e9) for k, v in enumerate(located.value))
        if low is None or high is None:
            return None
        if low > high:
            self.problem(located, where, f"the least, {low:g} mm, is more than the most, {high:g} mm")
            return None
        return float(low), float(high)

    def servos(self, located: Located, where: str) -> tuple[tuple[int, tuple[int, ...]], ...]:
        """``[{id: 0, angles: [-60, -30]}, ...]``: each angle a servo was sent to, in order."""
        why = "servos: is a list of {id: SERVO, angles: [...]}, e.g. [{id: 0, angles: [-60, 0, 60]}]"
        servos: dict[int, tuple[int, ...]] = {}
        for at, item, doc in self.mappings(located, where, why, SERVO_KEYS):
            missing = [key for key in SERVO_KEYS if key not in doc]
            if missing:
                self.problem(item, at, f"'{missing[0]}' is missing: {why}")
                continue
            servo = self.number(doc["id"], f"{at}.id", 0, 2, whole=True)
            given = doc["angles"]
            if not isinstance(given.value, list):
                self.problem(given, f"{at}.angles", "angles: is a list of whole degrees, -99 to 99, e.g. [-60, 0, 60]")
                continue
            angles = [self.number(v, f"{at}.angles[{j}]", -99, 99, whole=True) for j, v in enumerate(given.value)]
            if servo is None or None in angles:
                continue
            if servo in servos:
                self.problem(doc["id"], f"{at}.id", f"servo {servo} is named twice: say all its angles in one list")
                continue
            servos[int(servo)] = tuple(int(a) for a in angles)
        return tuple(sorted(servos.items()))

    def nodes(self, located: Located, where: str, nodes: list[NodeInfo]) -> list[NodeCheck]:
        if not isinstance(located.value, list) or not located.value:
            self.problem(located, where, "nodes: is a list, e.g. - {node: avoid, runs: true}")
            return []
        checks = []
        for index, item in enumerate(located.value):
            check = self.node(item, f"{where}[{index}]", nodes)
            if check is not None:
                checks.append(check)
        return checks

    def node(self, item: Located, where: str, nodes: list[NodeInfo]) -> NodeCheck | None:
        if not isinstance(item.value, dict):
            self.problem(item, where, "a node's check is a mapping, e.g. {node: avoid, reaches: SUCCESS, before_s: 10}")
            return None
        doc: dict[str, Located] = item.value
        self.known_keys(item, where, NODE_KEYS)
        if "node" not in doc:
            self.problem(item, where, "'node' is missing: the node's name, or its path from the root")
            return None
        node = self.text(doc["node"], f"{where}.node")
        ids = named(nodes, node) if node is not None else ()
        if node is not None and not ids:
            names = [n.name for n in nodes]
            self.problem(doc["node"], f"{where}.node", f"no node named '{node}' in the mission{suggest(node, names)}")
        kinds = [key for key in ("reaches", "never", "runs") if key in doc]
        if len(kinds) != 1:
            self.problem(item, where, "a node's check says one of reaches: STATUS, never: STATUS or runs: true/false")
            return None
        kind = kinds[0]
        if "before_s" in doc and kind != "reaches":
            self.problem(doc["before_s"], f"{where}.before_s", "before_s goes with reaches:")
        if "after_s" in doc and kind == "runs":
            self.problem(doc["after_s"], f"{where}.after_s", "after_s goes with reaches: or never:")
        if kind == "runs":
            if not isinstance(doc["runs"].value, bool):
                self.problem(
                    doc["runs"], f"{where}.runs", "runs: is true (the node runs at least once) or false (never)"
                )
                return None
            return NodeCheck(node or "", ids, "runs", expected=doc["runs"].value, line=item.line) if ids else None
        status_text = self.text(doc[kind], f"{where}.{kind}")
        status = status_text.upper() if status_text is not None else None
        if status is not None and status not in STATUSES:
            self.problem(doc[kind], f"{where}.{kind}", f"unknown status '{status_text}': one of {', '.join(STATUSES)}")
            return None
        time_key = "before_s" if kind == "reaches" else "after_s"
        time_s = self.number(doc[time_key], f"{where}.{time_key}", 0.0, MAX_TIME_LIMIT_S) if time_key in doc else None
        from_s = None
        if kind == "reaches" and "after_s" in doc:
            from_s = self.number(doc["after_s"], f"{where}.after_s", 0.0, MAX_TIME_LIMIT_S)
            if from_s is not None and time_s is not None and from_s >= time_s:
                self.problem(doc["after_s"], f"{where}.after_s", f"after_s ({from_s:g} s) must come before before_s "
                             f"({time_s:g} s): the window it is reached in")  # fmt: skip
                return None
        if status is None or not ids:
            return None
        time_s = None if time_s is None else float(time_s)
        from_s = None if from_s is None else float(from_s)
        return NodeCheck(node or "", ids, kind, status, time_s, line=item.line, from_s=from_s)


def load_scenarios(path: str | Path) -> ScenarioFile:
    """Reads and validates a scenario file, and the mission it tests (its plugins loaded, as ``autonomy run`` does).

    Raises:
        ScenariosInvalid: the file, or its mission, cannot be read or has problems (all of them).
    """
    path = Path(path)
    label = str(path)
    try:
        text = read_text(path)
    except UnreadableFile as err:
        raise ScenariosInvalid([Problem(label, err.line, err.column, "", f"cannot read it: {err.reason}")]) from None
    return scenarios_from_text(text, path, label)


def scenarios_from_text(text: str, path: Path, label: str) -> ScenarioFile:
    """Reads and validates scenarios given as text, as if the file at ``path`` held it (``label`` names it).

    Raises:
        ScenariosInvalid: the text, or its mission, has problems (all of them).
    """
    root, errors = parse(text)
    problems = [Problem(label, e.line, e.column, "", e.message) for e in errors]
    if root is None:
        raise ScenariosInvalid(problems or [Problem(label, 1, 1, "", "not a scenario file")])
    reader = _Reader(label, path.parent)
    mission, items = reader.file(root, path)
    problems += reader.problems
    if mission is None:
        raise ScenariosInvalid(problems)
    try:
        spec = load_mission(mission)
    except MissionInvalid as err:
        raise ScenariosInvalid(
            problems + [Problem(label, 1, 1, "mission", f"the mission {mission} it tests has problems:")] + err.problems
        ) from None
    except OSError as err:
        raise ScenariosInvalid(
            problems + [Problem(label, 1, 1, "mission", f"cannot read the mission it tests, {mission}: {err}")]
        ) from None
    nodes = describe_tree(build_tree(spec))
    reader.problems = []
    names: set[str] = set()
    scenarios = [reader.scenario(item, f"{reader.key}[{k}]", nodes, names) for k, item in enumerate(items)]
    problems += reader.problems
    if problems:
        raise ScenariosInvalid(problems)
    statuses = {}
    for node in nodes:
        known = spec.registry.get(node.type) if node.type in spec.registry.names() else None
        if known is not None:
            statuses[node.type] = known.statuses
    return ScenarioFile(path, mission, spec, nodes, [s for s in scenarios if s is not None], statuses)


def holds_tests(path: Path) -> bool:
    """Whether ``path`` is a mission with a ``tests:`` list of its own (its text looked at, not parsed)."""
    try:
        if path.name.endswith(SUFFIX) or path.suffix != ".yaml" or path.stat().st_size > MAX_TESTS_FILE_BYTES:
            return False
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError:
        return False
    if not re.search(r"\btests\b", text):  # most files: not read further
        return False
    root, _ = parse(text)  # quoted keys, a flow mapping: the mission's own keys, however written
    return root is not None and isinstance(root.value, dict) and {"tests", "tree"} <= set(root.value)


def find_scenario_files(paths: list[str | Path]) -> list[Path]:
    """The scenario files under ``paths``, sorted, once each (the same file by two names, once).

    A folder is searched for ``*.test.yaml`` and for missions with a ``tests:`` list; a file is taken as it is,
    and a mission's ``NAME.yaml`` stands for the ``NAME.test.yaml`` beside it, when there is one, and for its
    own ``tests:`` (with neither, it is taken, and its reader says what it is).
    """
    found: list[Path] = []
    for given in paths:
        path = Path(given)
        if path.is_dir():
            found += sorted([*path.rglob("*" + SUFFIX), *(p for p in path.rglob("*.yaml") if holds_tests(p))])
        elif not path.name.endswith(SUFFIX) and (mission_of_test(path).is_file() or holds_tests(path)):
            found += [mission_of_test(path)] if mission_of_test(path).is_file() else []
            found += [path] if holds_tests(path) else []
        else:
            found.append(path)
    seen: set[Path] = set()
    once = []
    for path in found:
        key = path.resolve() if path.exists() else path
        if key not in seen:
            seen.add(key)
            once.append(path)
    return once
