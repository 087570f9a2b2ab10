"""Exercise files: what a mission should achieve, in which world, on which seeds, for how many points.

An exercise is a YAML file (docs/exercises.md)::

    exercise: garage
    title: Park in the garage
    description: Drive into the garage at the end of the hall and stop there without touching a wall.
    world: garage
    time_limit_s: 30
    seeds: [1, 2, 3]
    allowed_nodes: [sequence, move, turn, beep]
    criteria:
      - end_in_zone: garage
        points: 5
      - max_collisions: 0
        points: 3

It is read like a mission: every problem at once, as ``FILE:LINE:COL``, with a did-you-mean.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

from autonomy.classroom.criteria import CriteriaReader, Criterion
from autonomy.classroom.results import SeedResult
from autonomy.classroom.secret import hidden_seed
from autonomy.emulator.faults import FaultSpec, FaultSpecError
from autonomy.emulator.profile import ProfileInvalid, load_profile
from autonomy.emulator.world import SHIPPED, World, WorldError, WorldInvalid, load_world, world_file
from autonomy.errors import AutonomyError
from autonomy.mission.registry import BUILTINS
from autonomy.source import Located, Problem, UnreadableFile, exists, is_file, parse, read_text, suggest

TOP_LEVEL = (
    "exercise",
    "title",
    "description",
    "world",
    "robot",
    "robot_start",
    "robot_points",
    "time_limit_s",
    "seeds",
    "hidden_seeds",
    "allowed_nodes",
    "criteria",
    "solution",
)
SEED_KEYS = ("seed", "noise_mm", "faults")
#: Who may start a student's run on one of the class's robots (``class serve --robot``).
ROBOT_STARTS = ("teacher", "when_asked")
#: Longest time limit an exercise may set, simulated seconds.
MAX_TIME_LIMIT_S = 3600.0
#: Most points an exercise may give a run on one of the class's robots (the teacher's mark of it).
MAX_ROBOT_POINTS = 1000.0
MAX_SEEDS = 100


@dataclass(frozen=True)
class Seed:
    """One run of every submission: the emulator's seed (start jitter, noise), sensor noise, link faults."""

    seed: int
    noise_mm: float = 0.0
    faults: str = ""
    hidden: int = 0

    @property
    def label(self) -> str:
        """``seed 3``, with its noise and faults when it has them; ``hidden seed 2`` for a hidden one."""
        if self.hidden:
            return f"hidden seed {self.hidden}"
        extra = [f"noise {self.noise_mm:g} mm"] if self.noise_mm else []
        extra += [f"faults {self.faults}"] if self.faults else []
        return f"seed {self.seed}" + (f" ({', '.join(extra)})" if extra else "")


@dataclass
class Exercise:
    """A validated exercise file."""

    name: str
    title: str
    description: str
    world: World
    world_ref: str
    time_limit_s: float
    seeds: list[Seed]
    allowed_nodes: tuple[str, ...] | None
    criteria: list[Criterion]
    source: str
    hidden_seeds: int = 0
    solution: str = ""
    #: The robot profile every seed runs as (its file's path), or empty: the emulator's defaults.
    robot_ref: str = ""
    #: Who starts a student's run on one of the class's robots: ``teacher`` (at the desk), or ``when_asked``
    #: (the queue's next run starts as soon as a robot is free).
    robot_start: str = "teacher"
    #: The most points the teacher may give a student's run on one of the class's robots, having watched it
    #: (their best-marked run counts, beside their hand-in); 0: runs on robots count for no marks.
    robot_points: float = 0.0

    @property
    def max_points(self) -> float:
        """The most a submission can score."""
        return sum(c.points for c in self.criteria)

    def with_secret(self, secret: bytes) -> Exercise:
        """The exercise with its hidden seeds added after the public ones, drawn from the teacher's ``secret``.

        The same secret always draws the same seeds for the same exercise; without it, nobody can
        tell which they are. A student's own grading runs the public seeds only.
        """
        hidden = [Seed(hidden_seed(secret, self.name, k), hidden=k) for k in range(1, self.hidden_seeds + 1)]
        return replace(self, seeds=[*self.seeds, *hidden])


class ExerciseInvalid(AutonomyError):
    """An exercise file with problems; :attr:`problems` lists every one."""

    def __init__(self, problems: list[Problem]) -> None:
        self.problems = sorted(problems, key=lambda p: (p.file, p.line, p.column))
        super().__init__("\n".join(str(p) for p in self.problems))


class ExerciseReader(CriteriaReader):
    """Reads an exercise file's values (its world, seeds, criteria...), noting each problem where it stands.

    Args:
        source: The file's name, as its problems say it.
        base_dir: Where a world file or a solution it names is looked for.
    """

    #: What the file is, as its problems say it (a world file is looked for beside it).
    kind = "exercise"

    def __init__(self, source: str, base_dir: Path) -> None:
        super().__init__(source)
        self.base_dir = base_dir

    def exercise(self, root: Located, default_name: str) -> Exercise | None:
        """The exercise the file's root holds (None: its problems noted)."""
        if not isinstance(root.value, dict):
            self.problem(root, "", "an exercise file is a mapping with world:, time_limit_s:, seeds: and criteria:")
            return None
        doc: dict[str, Located] = root.value
        if "criteria" not in doc and ("tree" in doc or "arena_mm" in doc):  # the files given the other way round
            why = (
                "this is a mission file, not an exercise: autonomy grade EXERCISE THIS_FILE"
                if "tree" in doc
                else "this is a world file, not an exercise: an exercise names its world with world:"
            )
            self.problem(root, "", why)
            return None
        for key in doc:
            if key not in TOP_LEVEL:
                self.problem(root.keys[key], key, f"unknown key '{key}'{suggest(key, list(TOP_LEVEL))}")
        for key in ("world", "time_limit_s", "seeds", "criteria"):
            if key not in doc:
                self.problem(root, "", f"'{key}' is missing")
        name = self.text(doc["exercise"], "exercise") if "exercise" in doc else default_name
        title = (self.text(doc["title"], "title") if "title" in doc else None) or name or default_name
        description = ((self.text(doc["description"], "description") if "description" in doc else "") or "").strip()
        world, world_ref = self.world(doc["world"]) if "world" in doc else (None, "")
        limit = (
            self.number(doc["time_limit_s"], "time_limit_s", 0.1, MAX_TIME_LIMIT_S) if "time_limit_s" in doc else None
        )
        seeds = self.seeds(doc["seeds"]) if "seeds" in doc else []
        hidden = (
            self.number(doc["hidden_seeds"], "hidden_seeds", 0, MAX_SEEDS, whole=True) if "hidden_seeds" in doc else 0
        )
        allowed = self.allowed(doc["allowed_nodes"]) if "allowed_nodes" in doc else None
        criteria = self.criteria(doc["criteria"], world) if "criteria" in doc else []
        solution = self.solution(doc["solution"]) if "solution" in doc else ""
        robot = self.robot(doc["robot"]) if "robot" in doc else ""
        robot_start = self.robot_start(doc["robot_start"]) if "robot_start" in doc else "teacher"
        robot_points = (
            self.number(doc["robot_points"], "robot_points", 0, MAX_ROBOT_POINTS) if "robot_points" in doc else 0
        )
        if self.problems or world is None or limit is None or name is None or solution is None or robot is None:
            return None
        return Exercise(
            name,
            title,
            description,
            world,
            world_ref,
            float(limit),
            seeds,
            allowed,
            criteria,
            self.label,
            int(hidden or 0),
            solution,
            robot,
            robot_start or "teacher",
            float(robot_points or 0),
        )

    def robot_start(self, located: Located) -> str | None:
        """Who starts a run on the class's robots (``teacher`` or ``when_asked``), or None and a problem noted."""
        value = self.text(located, "robot_start")
        if value is None:
            return None
        if value not in ROBOT_STARTS:
            self.problem(
                located,
                "robot_start",
                f"robot_start is 'teacher' (the teacher presses Start) or 'when_asked' (a run starts as soon as a "
                f"robot is free), not '{value}'{suggest(value, list(ROBOT_STARTS))}",
            )
            return None
        return value

    def robot(self, located: Located) -> str | None:
        """The robot profile file named there, beside the exercise (its path), or None and a problem noted."""
        name = self.text(located, "robot")
        if name is None:
            return None
        path = Path(name) if Path(name).is_absolute() else self.base_dir / name
        if not is_file(path):
            self.problem(located, "robot", f"the robot profile '{name}' is not there (beside the {self.kind}: {path})")
            return None
        try:
            load_profile(path)
        except ProfileInvalid as err:
            self.problem(
                located, "robot", f"the robot profile {path} is not valid ({len(err.problems)} listed with its name)"
            )
            self.problems += err.problems
            return None
        return str(path)

    def solution(self, located: Located) -> str | None:
        """The teacher's solution: a mission file beside the exercise, which ``autonomy check`` grades.

        Only ``autonomy check`` reads it, and says when it is not there: an exercise copied without
        its solution (to a grader, a Gradescope autograder, a live class) is graded all the same.
        """
        name = self.text(located, "solution")
        if name is None:
            return None
        return str(Path(name) if Path(name).is_absolute() else self.base_dir / name)

    def world(self, located: Located, where: str = "world") -> tuple[World | None, str]:
        """The world named there (a shipped one, or a file beside), and how it was named (None: a problem noted)."""
        name = self.text(located, where)
        if name is None:
            return None, ""
        ref = name
        path = world_file(name, self.base_dir)
        if path is not None:
            ref = str(path)
            if not is_file(path):
                if exists(path):
                    why = f"'{name}' is not a world file (a folder, a device or a pipe)"
                elif Path(name).suffix or "/" in name:  # a file's name: that file is missing
                    why = f"the world file '{name}' is not there (beside the {self.kind}: {path})"
                else:
                    hint = suggest(name, list(SHIPPED))
                    why = (
                        f"no world named '{name}'{hint}: use one of {', '.join(SHIPPED)}, or a world file beside the "
                        f"{self.kind} ({name}.yaml)"
                    )
                self.problem(located, where, why)
                return None, ""
        try:
            return load_world(ref), ref
        except WorldInvalid as err:
            self.problem(
                located, where, f"the world file {ref} is not valid ({len(err.problems)} listed with its name)"
            )
            self.problems += err.problems
        except WorldError as err:
            self.problem(located, where, str(err))
        return None, ""

    def seeds(self, located: Located) -> list[Seed]:
        """The seeds listed there (``[1, 2]``, or ``{seed: 4, noise_mm: 2, faults: ...}`` items), problems noted."""
        if not isinstance(located.value, list) or not located.value:
            self.problem(located, "seeds", "expected a list of seeds: [1, 2, 3], or {seed: 4, noise_mm: 2}")
            return []
        if len(located.value) > MAX_SEEDS:
            self.problem(located, "seeds", f"at most {MAX_SEEDS} seeds")
            return []
        seeds: list[Seed] = []
        for index, item in enumerate(located.value):
            path = f"seeds[{index}]"
            if isinstance(item.value, dict):
                fields = item.value
                for key in fields:
                    if key not in SEED_KEYS:
                        self.problem(
                            item.keys[key], f"{path}.{key}", f"unknown key '{key}'{suggest(key, list(SEED_KEYS))}"
                        )
                if "seed" not in fields:
                    self.problem(item, path, "'seed' is missing")
                    continue
                seed = self.number(fields["seed"], f"{path}.seed", 0, 2**31 - 1, whole=True)
                noise = self.number(fields["noise_mm"], f"{path}.noise_mm", 0, 100) if "noise_mm" in fields else 0.0
                faults = ""
                if "faults" in fields:
                    faults = self.text(fields["faults"], f"{path}.faults") or ""
                    try:
                        FaultSpec.parse(faults)
                    except FaultSpecError as err:
                        self.problem(fields["faults"], f"{path}.faults", str(err))
                if seed is not None and noise is not None:
                    seeds.append(Seed(int(seed), float(noise), faults))
            else:
                seed = self.number(item, path, 0, 2**31 - 1, whole=True)
                if seed is not None:
                    seeds.append(Seed(int(seed)))
        if len(set(seeds)) != len(seeds):
            self.problem(
                located, "seeds", "a seed is given twice with the same noise and faults: it would run the same"
            )
        return seeds

    def allowed(self, located: Located) -> tuple[str, ...] | None:
        """The node types listed there, as the registry names them (None: a problem noted)."""
        known = sorted(BUILTINS.names())
        if not isinstance(located.value, list) or not located.value:
            self.problem(located, "allowed_nodes", "expected a list of node types, e.g. [sequence, move, turn, beep]")
            return None
        names = []
        for index, item in enumerate(located.value):
            if not isinstance(item.value, str) or item.value not in known:
                word = item.value if isinstance(item.value, str) else repr(item.plain)
                hint = suggest(word, known) if isinstance(item.value, str) else ""
                self.problem(item, f"allowed_nodes[{index}]", f"unknown node type '{word}'{hint}")
                continue
            names.append(BUILTINS.get(item.value).name)
        return tuple(names)


def load_exercise(path: str | Path) -> Exercise:
    """Reads and validates an exercise file.

    Raises:
        ExerciseInvalid: the file cannot be read, or has problems (all of them).
    """
    path = Path(path)
    label = str(path)
    try:
        text = read_text(path)
    except UnreadableFile as err:
        raise ExerciseInvalid(
            [Problem(label, err.line, err.column, "", f"cannot read the exercise: {err.reason}")]
        ) from None
    root, errors = parse(text)
    problems = [Problem(label, e.line, e.column, "", e.message) for e in errors]
    reader = ExerciseReader(label, path.parent)
    exercise = reader.exercise(root, path.stem) if root is not None else None
    problems += reader.problems
    if problems or exercise is None:
        raise ExerciseInvalid(problems or [Problem(label, 1, 1, "", "not an exercise")])
    return exercise


def seed_points(exercise: Exercise, seed: SeedResult) -> float:
    """The points one seed's run earned: each criterion's points times its share there."""
    return sum(c.points * share for c, share in zip(exercise.criteria, seed.shares, strict=False))
