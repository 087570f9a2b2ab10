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
from typing import Any

from autonomy.classroom.criteria import CRITERIA
from autonomy.classroom.secret import hidden_seed
from autonomy.emulator.faults import FaultSpec, FaultSpecError
from autonomy.emulator.world import SHIPPED, World, WorldError, WorldInvalid, load_world, world_file
from autonomy.errors import AutonomyError
from autonomy.mission.registry import BUILTINS
from autonomy.source import Located, Problem, Reader, UnreadableFile, exists, is_file, parse, read_text, suggest

TOP_LEVEL = (
    "exercise",
    "title",
    "description",
    "world",
    "time_limit_s",
    "seeds",
    "hidden_seeds",
    "allowed_nodes",
    "criteria",
    "solution",
)
SEED_KEYS = ("seed", "noise_mm", "faults")
#: Longest time limit an exercise may set, simulated seconds.
MAX_TIME_LIMIT_S = 3600.0
MAX_SEEDS = 100
#: Longest title a criterion may have (what a student reads for it), characters.
MAX_TITLE_CHARS = 80


@dataclass(frozen=True)
class Criterion:
    """One thing a run is judged on, worth ``points``.

    Attributes:
        kind: The criterion's key (see :data:`CRITERIA`).
        value: Its value: a zone name, a number, or True.
        points: What it is worth when it holds on every seed.
        options: Its further settings (``within_mm``, ``tolerance_deg``, ``after``), defaults filled in.
        label: How the teacher's reports name it (``end_in_zone garage``): its id.
        title: What a student reads for it, in words (``Parked in the garage``: ``title:`` in the
            file); empty, and the label is shown.
        requires: The index of the criterion that must hold on a seed for this one to count
            there (``requires: end_in_zone`` in the file), or None.
        requires_some: That criterion need only earn some of its points there, and this one then
            earns the same part of its own (``requires_some:`` in the file: a near miss of
            ``rest_in_zone`` earns a part of "no collision" too).
    """

    kind: str
    value: Any
    points: float
    options: dict[str, float | str]
    label: str
    requires: int | None = None
    requires_some: bool = False
    title: str = ""

    @property
    def shown(self) -> str:
        """How a student's page, feedback and results name it: its title, else its label."""
        return self.title or self.label


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


class _Reader(Reader):
    def __init__(self, source: str, base_dir: Path) -> None:
        super().__init__(source)
        self.base_dir = base_dir

    def exercise(self, root: Located, default_name: str) -> Exercise | None:
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
        if self.problems or world is None or limit is None or name is None or solution is None:
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
        )

    def solution(self, located: Located) -> str | None:
        """The teacher's solution: a mission file beside the exercise, which ``autonomy check`` grades.

        Only ``autonomy check`` reads it, and says when it is not there: an exercise copied without
        its solution (to a grader, a Gradescope autograder, a live class) is graded all the same.
        """
        name = self.text(located, "solution")
        if name is None:
            return None
        return str(Path(name) if Path(name).is_absolute() else self.base_dir / name)

    def world(self, located: Located) -> tuple[World | None, str]:
        name = self.text(located, "world")
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
                    why = f"the world file '{name}' is not there (beside the exercise: {path})"
                else:
                    hint = suggest(name, list(SHIPPED))
                    why = (
                        f"no world named '{name}'{hint}: use one of {', '.join(SHIPPED)}, or a world file beside the "
                        f"exercise ({name}.yaml)"
                    )
                self.problem(located, "world", why)
                return None, ""
        try:
            return load_world(ref), ref
        except WorldInvalid as err:
            self.problem(
                located, "world", f"the world file {ref} is not valid ({len(err.problems)} listed with its name)"
            )
            self.problems += err.problems
        except WorldError as err:
            self.problem(located, "world", str(err))
        return None, ""

    def seeds(self, located: Located) -> list[Seed]:
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

    def criteria(self, located: Located, world: World | None) -> list[Criterion]:
        if not isinstance(located.value, list) or not located.value:
            self.problem(located, "criteria", "expected a list of criteria, e.g. - {end_in_zone: garage, points: 5}")
            return []
        read = []
        for index, item in enumerate(located.value):
            criterion = self.criterion(item, f"criteria[{index}]", world)
            if criterion is not None:
                read.append((criterion, item, f"criteria[{index}]"))
        return self.requirements(read)

    def criterion(self, item: Located, path: str, world: World | None) -> Criterion | None:
        if not isinstance(item.value, dict):
            self.problem(
                item,
                path,
                f"a criterion is a mapping, e.g. {{max_collisions: 0, points: 2}}; kinds: {', '.join(CRITERIA)}",
            )
            return None
        kinds = [key for key in item.value if key in CRITERIA]
        if len(kinds) != 1:
            unknown = [key for key in item.value if key not in CRITERIA and key not in ("points", "title")]
            if not kinds and unknown:
                word = unknown[0]
                self.problem(
                    item.keys[word], f"{path}.{word}", f"unknown criterion '{word}'{suggest(word, list(CRITERIA))}"
                )
            else:
                self.problem(item, path, f"give exactly one criterion of: {', '.join(CRITERIA)}")
            return None
        kind = CRITERIA[kinds[0]]
        allowed = (kind.key, "points", "title", "requires", "requires_some", *kind.options)
        for key in item.value:
            if key not in allowed:
                self.problem(
                    item.keys[key], f"{path}.{key}", f"unknown key '{key}' for {kind.key}{suggest(key, list(allowed))}"
                )
        points = self.number(item.value["points"], f"{path}.points", 0, 1000) if "points" in item.value else 1.0
        options = dict(kind.options)
        for key, default in kind.options.items():
            if key not in item.value:
                continue
            if isinstance(default, str) and key == "with":  # an obstacle's name
                name = self.obstacle_name(item.value[key], f"{path}.{key}", world)
                if name is not None:
                    options[key] = name
                continue
            if isinstance(default, str):  # a zone's name
                name = self.zone_name(item.value[key], f"{path}.{key}", world)
                if name is not None:
                    if kind.value == "zone" and item.value[kind.key].value == name:
                        self.problem(item.value[key], f"{path}.{key}", f"'{name}' is the zone itself: name another")
                    options[key] = name
                continue
            whole = key in ("extra_beeps", "count")
            got = self.number(item.value[key], f"{path}.{key}", 0, 100_000, whole=whole)
            if got is not None:
                options[key] = float(got)
        located = item.value[kind.key]
        where = f"{path}.{kind.key}"
        value: Any = None
        if kind.value == "zone":
            value = self.zone_name(located, where, world)
        elif kind.value == "zones":
            if not isinstance(located.value, list) or not located.value:
                self.problem(located, where, f"expected a list of zones, e.g. {kind.key}: [corner_1, corner_2]")
            else:
                names = [self.zone_name(item, f"{where}[{i}]", world) for i, item in enumerate(located.value)]
                if all(name is not None for name in names):
                    value = tuple(names)
                    if len(set(names)) != len(names):
                        self.problem(located, where, "a zone is named twice")
                        value = None
        elif kind.value == "count":
            value = self.number(located, where, 0, 1_000_000, whole=True)
        elif kind.value in ("seconds", "mm"):
            value = self.number(located, where, 0, 1e9)
        elif kind.value == "degrees":
            value = self.number(located, where, -360, 360)
        elif located.value is not True:
            self.problem(located, where, f"{kind.key} takes true, got {located.plain!r}")
        else:
            value = True
        if value is None or points is None:
            return None
        label = (
            kind.key
            if value is True
            else f"{kind.key} {value:g}"
            if isinstance(value, (int, float))
            else f"{kind.key} {' '.join(value)}"
            if isinstance(value, tuple)
            else f"{kind.key} {value}"
        )
        title = self.text(item.value["title"], f"{path}.title") if "title" in item.value else ""
        if title is not None and len(title) > MAX_TITLE_CHARS:
            self.problem(item.value["title"], f"{path}.title", f"at most {MAX_TITLE_CHARS} characters: a few words")
            title = None
        if title is None:
            return None
        return Criterion(kind.key, value, float(points), options, label, title=title)

    def obstacle_name(self, located: Located, where: str, world: World | None) -> str | None:
        """An obstacle's name (``name:`` in the world file), which the world must have."""
        value = self.text(located, where)
        names = [n for n in (world.obstacle_names if world is not None else ()) if n]
        if value is not None and world is not None and value not in names:
            listed = f" (its named obstacles: {', '.join(names)})" if names else " (it names none of its obstacles)"
            self.problem(
                located, where, f"world '{world.name}' has no obstacle named '{value}'{suggest(value, names)}{listed}"
            )
            return None
        return value

    def zone_name(self, located: Located, where: str, world: World | None) -> str | None:
        """A zone's name, which the world must have."""
        value = self.text(located, where)
        if value is not None and world is not None and world.zone(value) is None:
            names = [z.name for z in world.zones]
            listed = f" (its zones: {', '.join(names)})" if names else " (it has no zones)"
            self.problem(located, where, f"world '{world.name}' has no zone '{value}'{suggest(value, names)}{listed}")
            return None
        return value

    def requirements(self, criteria: list[tuple[Criterion, Located, str]]) -> list[Criterion]:
        """Resolves each ``requires:`` to the criterion it names (by kind, or by label when a kind repeats)."""
        out = []
        for index, (criterion, item, path) in enumerate(criteria):
            key = "requires_some" if "requires_some" in item.value else "requires"
            wanted = item.value.get(key)
            if "requires" in item.value and "requires_some" in item.value:
                self.problem(
                    item.keys["requires_some"], f"{path}.requires_some", "give requires or requires_some, not both"
                )
            if wanted is None:
                out.append(criterion)
                continue
            labels = [c.label for c, _, _ in criteria]
            named = [i for i, (c, _, _) in enumerate(criteria) if wanted.value in (c.kind, c.label)]
            if not isinstance(wanted.value, str) or len(named) != 1 or named[0] == index:
                word = wanted.value if isinstance(wanted.value, str) else repr(wanted.plain)
                why = (
                    "names more than one criterion: give its whole label"
                    if len(named) > 1
                    else "names no other criterion"
                )
                hint = suggest(word, labels) if isinstance(wanted.value, str) else ""
                self.problem(wanted, f"{path}.{key}", f"'{word}' {why}{hint} (criteria: {', '.join(labels)})")
                out.append(criterion)  # kept in its place, so that the indexes below hold
                continue
            out.append(replace(criterion, requires=named[0], requires_some=key == "requires_some"))
        for index, criterion in enumerate(out):  # a chain of requirements must end somewhere
            seen, at = {index}, criterion.requires
            while at is not None and at not in seen:
                seen.add(at)
                at = out[at].requires
            if at == index:
                _, item, path = criteria[index]
                key = "requires_some" if "requires_some" in item.value else "requires"
                self.problem(item.value[key], f"{path}.{key}", "requirements go round in a circle")
        return out


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
    reader = _Reader(label, path.parent)
    exercise = reader.exercise(root, path.stem) if root is not None else None
    problems += reader.problems
    if problems or exercise is None:
        raise ExerciseInvalid(problems or [Problem(label, 1, 1, "", "not an exercise")])
    return exercise
