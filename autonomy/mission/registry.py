"""The one registry of node types: parameters, units, ranges, a line of doc, how to build each.

The validator, ``autonomy behaviours``, ``autonomy schema`` and docs/missions.md all read
it. Leaves come from their classes' declarations (:class:`~autonomy.behaviours.base.RobotBehaviour`);
composites and decorators are declared here. A mission's plugins add leaves to a copy of
the built-in registry, never to the built-in one itself.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import py_trees
from py_trees.common import OneShotPolicy, ParallelPolicy

from autonomy.behaviours import BUILTIN_ACTIONS, BUILTIN_CONDITIONS, ClockTimeout, Param, RobotBehaviour
from autonomy.behaviours.base import MAX_SECONDS
from autonomy.behaviours.choice import RandomChoice
from autonomy.behaviours.decorators import Repeat, Retry

Behaviour = py_trees.behaviour.Behaviour
#: Builds a node from its display name, validated arguments and built children.
Builder = Callable[[str, dict[str, Any], list[Behaviour]], Behaviour]

CATEGORIES = ("composite", "decorator", "action", "condition", "reference")


@dataclass(frozen=True)
class NodeType:
    """One kind of node a mission file may use.

    Attributes:
        name: The key in a mission file.
        category: One of :data:`CATEGORIES`.
        doc: One line for the catalogue and the docs.
        params: The parameters it takes (``name:`` is allowed on every node besides).
        build: Makes the py_trees behaviour.
        label: Makes the display name when the file gives none.
        exactly_one_of: Groups of parameters of which exactly one must be given.
        aliases: Other names for the same type.
        children_param: For composites, the parameter that a short form (a bare list) fills.
        origin: ``built-in`` or the plugin module that declared it.
        statuses: The statuses a node of the type can return (what a mission's tests can cover).
    """

    name: str
    category: str
    doc: str
    params: tuple[Param, ...]
    build: Builder
    label: Callable[[dict[str, Any]], str]
    exactly_one_of: tuple[tuple[str, ...], ...] = ()
    aliases: tuple[str, ...] = ()
    children_param: str = ""
    origin: str = "built-in"
    statuses: tuple[str, ...] = ("SUCCESS", "FAILURE", "RUNNING")

    def param(self, name: str) -> Param | None:
        """The parameter called ``name``, or None."""
        return next((p for p in self.params if p.name == name), None)

    @property
    def needs_parameters(self) -> bool:
        """Whether the node cannot be written as a bare string."""
        return self.category in ("composite", "decorator", "reference") or bool(
            self.exactly_one_of or any(p.required for p in self.params)
        )


def _leaf_label(cls: type[RobotBehaviour]) -> Callable[[dict[str, Any]], str]:
    def label(args: dict[str, Any]) -> str:
        text = cls.node_type.replace("_", " ")
        values = [f"{args[p.name]}{' ' + p.unit if p.unit else ''}" for p in cls.params if p.required]
        return " ".join([text, *values])

    return getattr(cls, "label", None) or label


def leaf_type(cls: type[RobotBehaviour], origin: str = "built-in") -> NodeType:
    """Makes the node type a leaf class declares.

    Raises:
        ValueError: the class declares its node type wrongly (the message says how to mend it).
    """
    name = cls.__name__
    if not isinstance(cls.node_type, str) or not cls.node_type.isidentifier():
        raise ValueError(f"{name}.node_type must be a name such as 'turn_until_clear', got {cls.node_type!r}")
    if not isinstance(cls.params, tuple) or not all(isinstance(p, Param) for p in cls.params):
        raise ValueError(f"{name}.params must be a tuple of Param(...), got {cls.params!r}"[:200])
    if not isinstance(cls.exactly_one_of, tuple):
        raise ValueError(f"{name}.exactly_one_of must be a tuple of tuples of parameter names")
    if not cls.statuses or not set(cls.statuses) <= {"SUCCESS", "FAILURE", "RUNNING"}:
        raise ValueError(f"{name}.statuses must name some of SUCCESS, FAILURE and RUNNING, got {cls.statuses!r}"[:200])
    if not isinstance(cls.doc, str):
        raise ValueError(f"{name}.doc must be one line of text, got {cls.doc!r}"[:200])
    described = (cls.__doc__ or "").strip().splitlines()
    return NodeType(
        name=cls.node_type,
        category=cls.category,
        doc=cls.doc or (described[0] if described else f"{cls.node_type} (from {origin})"),
        params=cls.params,
        build=lambda name, args, children: cls(name, **args),
        label=_leaf_label(cls),
        exactly_one_of=cls.exactly_one_of,
        origin=origin,
        statuses=tuple(cls.statuses),
    )


# --------------------------------------------------------------------------- composites, decorators

NAME = Param("name", "string", "display name in the tree, the live view and the trace")
DO = Param("do", "node", "the child", required=True, example="{move: {speed: 2}}")
CHILDREN = Param("children", "nodes", "the children, in order", required=True)


def _composite(name: str, doc: str, extra: tuple[Param, ...], build: Builder, label: str, aliases=()) -> NodeType:
    return NodeType(
        name,
        "composite",
        doc,
        (*extra, CHILDREN),
        build,
        lambda args: label,
        aliases=aliases,
        children_param="children",
    )


def _decorator(
    name: str, doc: str, extra: tuple[Param, ...], build: Builder, label: Callable, statuses: tuple[str, ...] = ()
) -> NodeType:
    return NodeType(name, "decorator", doc, (*extra, DO), build, label, statuses=statuses or NodeType.statuses)


def _only(children: list[Behaviour]) -> Behaviour:
    return children[0]


BUILTIN_STRUCTURE = (
    _composite(
        "sequence",
        "Run children in order; fails as soon as one fails.",
        (Param("memory", "bool", "false: re-check earlier children every tick", default=True),),
        lambda n, a, c: py_trees.composites.Sequence(n, memory=a["memory"], children=c),
        "sequence",
    ),
    _composite(
        "selector",
        "Try children in order of priority; succeeds with the first that succeeds. A higher one preempts a lower.",
        (Param("memory", "bool", "true: resume the running child instead of re-checking higher ones", default=False),),
        lambda n, a, c: py_trees.composites.Selector(n, memory=a["memory"], children=c),
        "selector",
        aliases=("fallback",),
    ),
    _composite(
        "parallel",
        "Tick all children every tick; all: succeed when all have, one: when one has. Fails when one fails.",
        (Param("policy", "choice", "when the parallel succeeds", default="all", choices=("all", "one")),),
        lambda n, a, c: py_trees.composites.Parallel(
            n,
            policy=ParallelPolicy.SuccessOnAll(synchronise=True)
            if a["policy"] == "all"
            else ParallelPolicy.SuccessOnOne(),
            children=c,
        ),
        "parallel",
    ),
    _composite(
        "random",
        "Run one child, picked at random each time it starts (each as likely); the same seed picks the same.",
        (
            Param(
                "seed",
                "int",
                "the seed of its picks (default: the run's seed, the emulator's, so a scenario's seed replays them)",
                minimum=0,
                maximum=2**31 - 1,
                example=7,
            ),
        ),
        lambda n, a, c: RandomChoice(n, c, a["seed"]),
        "random",
    ),
    _decorator(
        "repeat",
        "Run the child again each time it succeeds: times times, or forever. Fails when the child fails.",
        (Param("times", "int", "how many successes (forever when left out)", minimum=1, maximum=1_000_000, example=4),),
        lambda n, a, c: Repeat(n, _only(c), num_success=a["times"] or -1),
        lambda a: f"repeat x{a['times']}" if a.get("times") else "repeat forever",
    ),
    _decorator(
        "retry",
        "Run the child again each time it fails, up to attempts tries in all.",
        (Param("attempts", "int", "tries in all", required=True, minimum=1, maximum=1000, example=3),),
        lambda n, a, c: Retry(n, _only(c), num_failures=a["attempts"]),
        lambda a: f"retry x{a['attempts']}",
    ),
    _decorator(
        "timeout",
        "Fail, halting the child, if it is still running after seconds.",
        (
            Param(
                "seconds",
                "number",
                "time allowed",
                unit="s",
                required=True,
                positive=True,
                maximum=MAX_SECONDS,
                example=10,
            ),
        ),
        lambda n, a, c: ClockTimeout(n, _only(c), a["seconds"]),
        lambda a: f"timeout {a['seconds']} s",
    ),
    _decorator(
        "invert",
        "Success becomes failure and failure success.",
        (),
        lambda n, a, c: py_trees.decorators.Inverter(n, _only(c)),
        lambda a: "invert",
    ),
    _decorator(
        "force_success",
        "Failure becomes success (running stays running).",
        (),
        lambda n, a, c: py_trees.decorators.FailureIsSuccess(n, _only(c)),
        lambda a: "force success",
        ("SUCCESS", "RUNNING"),
    ),
    _decorator(
        "force_failure",
        "Success becomes failure (running stays running).",
        (),
        lambda n, a, c: py_trees.decorators.SuccessIsFailure(n, _only(c)),
        lambda a: "force failure",
        ("FAILURE", "RUNNING"),
    ),
    _decorator(
        "once",
        "Run the child to completion once; afterwards return that result without running it.",
        (),
        lambda n, a, c: py_trees.decorators.OneShot(n, _only(c), policy=OneShotPolicy.ON_COMPLETION),
        lambda a: "once",
    ),
    NodeType(
        "while",
        "decorator",
        "Run do while condition holds, re-checking it every tick; when it fails, do is halted and while fails.",
        (Param("condition", "node", "checked before do on every tick", required=True, example="healthy"), DO),
        # A sequence without memory is exactly this: the condition first, every tick.
        lambda n, a, c: py_trees.composites.Sequence(n, memory=False, children=c),
        lambda a: "while",
    ),
    NodeType(
        "subtree",
        "reference",
        "Insert the named tree from the mission's subtrees.",
        (Param("subtree", "string", "the subtree's name", required=True),),
        lambda n, a, c: _only(c),
        lambda a: a["subtree"],
    ),
)


class Registry:
    """Node types by name (and alias)."""

    def __init__(self, types: tuple[NodeType, ...] = ()) -> None:
        self._types: dict[str, NodeType] = {}
        self._aliases: dict[str, str] = {}
        for node_type in types:
            self.add(node_type)

    def add(self, node_type: NodeType) -> None:
        """Adds a node type.

        Raises:
            ValueError: the name or an alias is taken already.
        """
        for name in (node_type.name, *node_type.aliases):
            if name in self._types or name in self._aliases:
                taken = self.get(name)
                raise ValueError(f"node type '{name}' is already defined ({taken.origin if taken else ''})")
        self._types[node_type.name] = node_type
        for alias in node_type.aliases:
            self._aliases[alias] = node_type.name

    def get(self, name: str) -> NodeType | None:
        """The node type called ``name`` (or with that alias), or None."""
        return self._types.get(self._aliases.get(name, name))

    def names(self) -> list[str]:
        """Every name and alias, for suggestions."""
        return [*self._types, *self._aliases]

    def __iter__(self) -> Iterator[NodeType]:
        return iter(self._types.values())

    def copy(self) -> Registry:
        """A registry with the same types, to extend without touching this one."""
        return Registry(tuple(self))


BUILTINS = Registry(
    (
        *BUILTIN_STRUCTURE,
        *(leaf_type(cls) for cls in BUILTIN_ACTIONS),
        *(leaf_type(cls) for cls in BUILTIN_CONDITIONS),
    )
)


def leaf_classes_in(module: Any) -> list[type[RobotBehaviour]]:
    """The leaf classes a plugin module declares (subclasses with a ``node_type`` of their own).

    A package's classes may live in its own modules; classes it imports from elsewhere (the
    built-in ones, another plugin's) are not its.
    """
    found = []
    for value in vars(module).values():
        if (
            isinstance(value, type)
            and issubclass(value, RobotBehaviour)
            and (value.__module__ == module.__name__ or value.__module__.startswith(f"{module.__name__}."))
            and "node_type" in vars(value)
            and value.node_type
        ):
            found.append(value)
    return found
