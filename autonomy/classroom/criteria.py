"""The kinds of criteria an exercise may mark, each with its parameters (docs/exercises.md), and their reading."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field, replace
from typing import Any

from autonomy.emulator.world import World
from autonomy.mission.registry import BUILTINS
from autonomy.source import Located, Reader, suggest


@dataclass(frozen=True)
class CriterionKind:
    """One kind of criterion: its key, what its value is, its options and their defaults.

    Attributes:
        key: The key that names it in a criteria item (``end_in_zone``).
        value: ``zone`` (a zone of the world), ``zones`` (a list of them), ``count`` (a whole
            number >= 0), ``seconds``, ``mm``, ``degrees``, ``range`` (two distances, mm, the
            nearer first), ``nodes`` (node types, or ``type.parameter``) or ``true`` (the value
            must be true).
        summary: What it asks, for the docs.
        options: Further keys it takes, with their defaults: a number, a flag (true or false), or
            a zone's name (a text).
    """

    key: str
    value: str
    summary: str
    options: dict[str, float | str | bool] = field(default_factory=dict)


#: How near a zone a robot that missed it earns a part of its points, by default (the part less, the further out):
#: a miss by a little is not a miss by a metre. ``near_mm: 0`` makes a zone all or nothing.
NEAR_MM = 100.0

CRITERIA = {
    kind.key: kind
    for kind in (
        CriterionKind(
            "reach_zone",
            "zone",
            "the robot's centre is in the zone at some moment; coming within near_mm of it earns a part, less the "
            "further out (near_mm: 0, all or nothing)",
            {"near_mm": NEAR_MM},
        ),
        CriterionKind(
            "visit_in_order",
            "zones",
            "the robot's centre is in each zone in turn, in the order given; each zone is its share",
        ),
        CriterionKind(
            "rest_in_zone",
            "zone",
            "the robot comes to rest for good by itself inside the zone within the time limit (after the zone "
            "'after', if set); within near_mm of it, at rest clear of walls and obstacles, earns a part, less the "
            "further out (near_mm: 0, all or nothing)",
            {"after": "", "near_mm": NEAR_MM},
        ),
        CriterionKind(
            "end_in_zone",
            "zone",
            "the mission ends on its own and the robot comes to rest by itself inside the zone; ending within "
            "near_mm of it, at rest clear of walls and obstacles, earns a part, less the further out (near_mm: 0, "
            "all or nothing)",
            {"near_mm": NEAR_MM},
        ),
        CriterionKind(
            "stop_in_zone",
            "zone",
            "the robot stands still with its centre in the zone for at least for_s seconds, at any time of its run",
            {"for_s": 0.5},
        ),
        CriterionKind("avoid_zone", "zone", "the robot's centre never enters the zone"),
        CriterionKind(
            "max_collisions",
            "count",
            "at most this many collisions (with the obstacle with: names only; with the robot's centre in zone at:; "
            "only those that hit faster than over_mm_s)",
            {"with": "", "at": "", "over_mm_s": 0.0},
        ),
        CriterionKind(
            "min_collisions",
            "count",
            "at least this many collisions (with the obstacle with: names only; with the robot's centre in zone at:; "
            "only those that hit faster than over_mm_s)",
            {"with": "", "at": "", "over_mm_s": 0.0},
        ),
        CriterionKind("finish_within_s", "seconds", "the mission succeeds within this many seconds"),
        CriterionKind("max_distance_mm", "mm", "the robot drives at most this far, forward and back"),
        CriterionKind(
            "beeps_in",
            "zones",
            "a beep at each zone (each its share), and no more than extra_beeps more, anywhere (else nothing); "
            "with standing, only beeps made standing count",
            {"within_mm": 0.0, "extra_beeps": 0.0, "standing": False},
        ),
        CriterionKind(
            "beep_near",
            "zone",
            "a beep while the robot's centre is within within_mm of the zone (with standing, made standing)",
            {"within_mm": 0.0, "standing": False},
        ),
        CriterionKind(
            "end_heading_deg", "degrees", "the robot ends facing this heading, give or take", {"tolerance_deg": 10.0}
        ),
        CriterionKind(
            "turns",
            "degrees",
            "the robot turns in place by this much (left positive, as a heading changes), at least count times "
            "(only at least after_drive_mm from where it turned before, in a straight line, if set; only with its "
            "centre in zone at:, if set)",
            {"count": 1.0, "tolerance_deg": 10.0, "after_drive_mm": 0.0, "at": ""},
        ),
        CriterionKind(
            "rest_distance_ahead_mm",
            "range",
            "the robot comes to rest for good by itself within the time limit with what lies straight ahead of its "
            "front between the two distances",
        ),
        CriterionKind("max_nodes", "count", "the mission's tree has at most this many nodes"),
        CriterionKind(
            "uses_nodes",
            "nodes",
            "the mission's tree has a node of one of these types (or, as type.parameter, one given that parameter)",
        ),
        CriterionKind("succeed", "true", "the mission succeeds (does not fail, crash or run out of time)"),
    )
}


#: How a criterion names the one it depends on: ``requires`` (it earns the part that one earned),
#: ``requires_some`` (the same: its older name), ``requires_all`` (only where that one held in full).
REQUIRES_KEYS = ("requires", "requires_some", "requires_all")

#: What an option may be, where it is not 0 to 100,000: a tolerance of a heading beyond a half-turn takes any
#: heading; a stop shorter than a tick (at 20 Hz) is no stop that a run can show.
OPTION_RANGES = {"tolerance_deg": (0, 90), "for_s": (0.05, 3600)}

#: Longest title a criterion may have (what a student reads for it), characters.
MAX_TITLE_CHARS = 80


@dataclass(frozen=True)
class Criterion:
    """One thing a run is judged on, worth ``points``.

    Attributes:
        kind: The criterion's key (see :data:`CRITERIA`).
        value: Its value: a zone name, a number, or True.
        points: What it is worth when it holds on every seed.
        options: Its further settings (``within_mm``, ``tolerance_deg``, ``after``, ``standing``), defaults
            filled in.
        label: How the teacher's reports name it (``end_in_zone garage``): its id.
        title: What a student reads for it, in words (``Parked in the garage``: ``title:`` in the
            file); empty, and the label is shown.
        requires: The index of the criterion this one depends on (``requires: end_in_zone`` in the file),
            or None. On each seed this one earns the part of its own that that one earned there: a near
            miss of ``rest_in_zone`` earns a part of "no crash" too, and missing it altogether nothing.
        requires_all: That criterion must hold in full on a seed for this one to count there at all
            (``requires_all:`` in the file): all or nothing, said so by the teacher.
    """

    kind: str
    value: Any
    points: float
    options: dict[str, float | str | bool]
    label: str
    requires: int | None = None
    requires_all: bool = False
    title: str = ""

    @property
    def shown(self) -> str:
        """How a student's page, feedback and results name it: its title, else its label."""
        return self.title or self.label


class CriteriaReader(Reader):
    """A :class:`Reader` that also reads an exercise's ``criteria:``, each checked against its world."""

    def criteria(self, located: Located, world: World | None) -> list[Criterion]:
        """The criteria list, each read and its requirements resolved; its problems noted."""
        if not isinstance(located.value, list) or not located.value:
            self.problem(located, "criteria", "expected a list of criteria, e.g. - {end_in_zone: garage, points: 5}")
            return []
        read = []
        for index, item in enumerate(located.value):
            criterion = self.criterion(item, f"criteria[{index}]", world)
            if criterion is not None:
                read.append((criterion, item, f"criteria[{index}]"))
        return self.requirements(self.told_apart(read))

    def told_apart(self, read: list[tuple[Criterion, Located, str]]) -> list[tuple[Criterion, Located, str]]:
        """Criteria of one label (``turns 180``, at two zones) labelled with their options too (``turns 180 at mid``).

        A label is what the teacher's gradebook, ``--compare`` and ``requires:`` name a criterion by:
        two alike but for an option get it added; two alike in every way are a problem.
        """
        labels = Counter(c.label for c, _, _ in read)
        out = []
        for criterion, item, path in read:
            if labels[criterion.label] > 1:
                defaults = CRITERIA[criterion.kind].options
                extra = [
                    key if value is True else f"{key} {value:g}" if isinstance(value, float) else f"{key} {value}"
                    for key, value in criterion.options.items()
                    if value != defaults[key]
                ]
                criterion = replace(criterion, label=" ".join([criterion.label, *extra]))
            out.append((criterion, item, path))
        seen: dict[str, str] = {}
        for criterion, item, path in out:
            if criterion.label in seen:
                self.problem(
                    item, path, f"the same criterion as {seen[criterion.label]} ('{criterion.label}'): give it once"
                )
            seen.setdefault(criterion.label, path)
        return out

    def criterion(self, item: Located, path: str, world: World | None) -> Criterion | None:
        """One criterion: its kind, value, points, options and title (None, its problems noted)."""
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
        allowed = (kind.key, "points", "title", *REQUIRES_KEYS, *kind.options)
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
            if isinstance(default, bool):  # a flag
                flag = item.value[key]
                if not isinstance(flag.value, bool):
                    self.problem(flag, f"{path}.{key}", f"{key} takes true or false, got {flag.plain!r}")
                else:
                    options[key] = flag.value
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
            low, high = OPTION_RANGES.get(key, (0, 100_000))
            got = self.number(item.value[key], f"{path}.{key}", low, high, whole=whole)
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
        elif kind.value == "degrees" and kind.key == "turns":  # a change of heading, within a half-turn either way
            value = self.number(located, where, -180, 180)
            tolerance_deg = float(options["tolerance_deg"])
            if value is not None and abs(value) <= tolerance_deg:
                self.problem(
                    located,
                    where,
                    f"a turn of {value:g} ± {tolerance_deg:g} degrees would count a robot that never turned: give a "
                    "turn larger than its tolerance (a whole turn ends where it began, and the path cannot tell it "
                    "from none)",
                )
                value = None
        elif kind.value == "degrees":
            value = self.number(located, where, -360, 360)
        elif kind.value == "range":
            value = self.distances(located, where)
        elif kind.value == "nodes":
            value = self.node_names(located, where)
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
            else f"{kind.key} {' '.join(v if isinstance(v, str) else f'{v:g}' for v in value)}"
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

    def distances(self, located: Located, where: str) -> tuple[float, float] | None:
        """Two distances, mm, the nearer first: ``[100, 200]``."""
        if not isinstance(located.value, list) or len(located.value) != 2:
            self.problem(located, where, "expected two distances in mm, the nearer first, e.g. [100, 200]")
            return None
        low, high = (self.number(item, f"{where}[{i}]", 0, 1e6) for i, item in enumerate(located.value))
        if low is None or high is None:
            return None
        if low > high:
            self.problem(located, where, f"the nearer distance first: [{high:g}, {low:g}]")
            return None
        return float(low), float(high)

    def node_names(self, located: Located, where: str) -> tuple[str, ...] | None:
        """Node types, each maybe with one of its parameters: ``[obstacle_within, move.until_obstacle_mm]``."""
        if not isinstance(located.value, list) or not located.value:
            self.problem(
                located, where, "expected a list of node types, e.g. [obstacle_within, move.until_obstacle_mm]"
            )
            return None
        known = sorted(BUILTINS.names())
        names: list[str] = []
        for index, item in enumerate(located.value):
            here = f"{where}[{index}]"
            if not isinstance(item.value, str):
                self.problem(item, here, f"expected a node type, got {item.plain!r}")
                continue
            node, _, param = item.value.partition(".")
            if node == "subtree":
                self.problem(item, here, "a subtree is its steps when graded: name the nodes its steps use")
                continue
            if node not in known:
                self.problem(item, here, f"unknown node type '{node}'{suggest(node, known)}")
                continue
            kind = BUILTINS.get(node)
            params = [p.name for p in kind.params if p.name not in ("children", "do", "condition")]
            if param and param not in params:
                listed = f" (its parameters: {', '.join(params)})" if params else " (it has none)"
                self.problem(item, here, f"{kind.name} has no parameter '{param}'{suggest(param, params)}{listed}")
                continue
            names.append(f"{kind.name}.{param}" if param else kind.name)
        if len(names) != len(located.value):
            return None
        return tuple(names)

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
            given = [key for key in REQUIRES_KEYS if key in item.value]
            key = given[0] if given else "requires"
            wanted = item.value.get(key)
            if len(given) > 1:
                self.problem(
                    item.keys[given[1]],
                    f"{path}.{given[1]}",
                    f"give one of {', '.join(REQUIRES_KEYS)}, not {len(given)}",
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
            out.append(replace(criterion, requires=named[0], requires_all=key == "requires_all"))
        for index, criterion in enumerate(out):  # a chain of requirements must end somewhere
            seen, at = {index}, criterion.requires
            while at is not None and at not in seen:
                seen.add(at)
                at = out[at].requires
            if at == index:
                _, item, path = criteria[index]
                key = next(key for key in REQUIRES_KEYS if key in item.value)
                self.problem(item.value[key], f"{path}.{key}", "requirements go round in a circle")
        return out
