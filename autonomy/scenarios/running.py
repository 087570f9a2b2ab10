"""Running a mission's scenarios: each seed in virtual time, what it expects checked, its nodes' statuses watched.

A scenario's run is judged as a grading judges one (:func:`~autonomy.classroom.job.run_seed`, the
emulator's own account), and each of its nodes' statuses is followed from the run's records, so
that what a node did, and which of its statuses no scenario ever saw, can be told.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field

from autonomy.classroom.child import end_with
from autonomy.classroom.exercise import Seed
from autonomy.classroom.facts import RunFacts
from autonomy.classroom.job import run_seed, verdicts_of
from autonomy.clock import cpu_time_s
from autonomy.errors import LinkError
from autonomy.record import NodeInfo, Record, RunEnd, RunHeader, TickRecord
from autonomy.runner import FAILED, INTERRUPTED, SUCCEEDED, TIME_LIMIT
from autonomy.scenarios.files import STATUSES, NodeCheck, Scenario, ScenarioFile
from autonomy.words import plural


class NodeWatch:
    """A listener that keeps, for each node, when its status changed and to what.

    Attributes:
        changes: By node id, each (time_s, status) its status changed to, in order.
        end_s: When the run ended (its end record's time).
    """

    def __init__(self) -> None:
        self.changes: dict[int, list[tuple[float, str]]] = {}
        self.end_s = 0.0

    def __call__(self, record: Record) -> None:
        """Takes one record."""
        if type(record) is TickRecord:
            for node, state in record.nodes.items():
                self.changes.setdefault(node, []).append((record.time_s, state.status))
        elif isinstance(record, RunHeader):
            self.changes, self.end_s = {}, 0.0
        elif isinstance(record, RunEnd):
            self.end_s = record.time_s

    def seen(self, node: int) -> set[str]:
        """The statuses ``node`` returned in the run (of SUCCESS, FAILURE and RUNNING)."""
        return {status for _, status in self.changes.get(node, []) if status in STATUSES}

    def holds(self, check: NodeCheck, paths: list[str] | None = None) -> tuple[bool, str]:
        """Whether ``check`` held in this run, for each node it names; where not, what one of them did instead.

        A check that names several nodes (a type, or a name some share) holds when it holds for every one
        of them; ``paths`` (each node's path of names, by id) says which one did not.
        """
        for node in check.ids:
            held, instead = self._holds(check, node)
            if not held:
                if len(check.ids) > 1 and paths is not None and node < len(paths):
                    instead = f"'{paths[node]}' (one of the {len(check.ids)} it names): {instead}"
                return False, instead
        return True, ""

    def _holds(self, check: NodeCheck, node: int) -> tuple[bool, str]:
        changes = self.changes.get(node, [])
        if check.kind == "runs":
            ran = [t for t, s in changes if s in STATUSES]
            if check.expected:
                return bool(ran), "it never ran"
            return not ran, f"it ran at {min(ran):g} s" if ran else ""
        if check.kind == "reaches":
            every = [t for t, s in changes if s == check.status]
            from_s = check.from_s or 0.0
            times = [t for t in every if t >= from_s - 1e-9]
            if every and not times:  # after_s asks for a turn to the status from then on, not one kept from before
                return False, (
                    f"it turned {check.status} only before {from_s:g} s (last at {max(every):g} s), and not again "
                    "from then on"
                )
            if not times:
                others = sorted({s for _, s in changes if s in STATUSES})
                return False, f"it never returned {check.status}" + (f" (only {', '.join(others)})" if others else "")
            first = min(times)
            if check.time_s is not None and first > check.time_s:
                since = f" (from {from_s:g} s on)" if check.from_s is not None else ""
                return False, f"it first returned {check.status}{since} at {first:g} s"
            return True, ""
        after_s = check.time_s or 0.0
        for k, (t, status) in enumerate(changes):
            until_s = changes[k + 1][0] if k + 1 < len(changes) else self.end_s
            # it was that status from t until its next change: at some moment after after_s?
            if status == check.status and (t >= after_s or until_s > after_s):
                return False, f"it was {status} at {max(t, after_s):g} s"
        return True, ""


#: The outcomes a scenario that names none takes: the mission ended, or its time ran out; not a crash, a lost
#: link or an interruption, which are never what a scenario tests unless it says so.
ENDED_AS_WRITTEN = (SUCCEEDED, FAILED, TIME_LIMIT)


def _ended(outcome: str) -> str:
    """An outcome after "the mission": ``succeeded``, ``was stopped at the time limit``, ``lost the link``..."""
    return f"was {outcome}" if outcome.startswith("stopped") or outcome == INTERRUPTED else outcome


@dataclass
class SeedOutcome:
    """One seed's run of a scenario: whether it held, and each thing that did not.

    Attributes:
        seed: The seed, as an exercise labels it (``seed 2 (noise 3 mm)``).
        outcome: The run's outcome.
        time_s: When the mission ended.
        failures: What was expected and what happened instead, one line each (empty: it held).
        running: The node that was running when the run went wrong (empty: none named).
    """

    seed: str
    outcome: str
    time_s: float
    failures: list[str] = field(default_factory=list)
    running: str = ""


@dataclass
class ScenarioOutcome:
    """A scenario's runs, one a seed.

    Attributes:
        file: The scenario file.
        name: The scenario's name.
        line: Where it starts in its file.
        seeds: Each seed's run.
        simulated_s: The simulated seconds its runs took in all.
        cpu_s: The CPU time its runs took, seconds.
    """

    file: str
    name: str
    line: int
    seeds: list[SeedOutcome]
    simulated_s: float
    cpu_s: float = 0.0

    @property
    def passed(self) -> bool:
        """Whether every seed held."""
        return all(not seed.failures for seed in self.seeds)

    @property
    def report(self) -> str:
        """What did not hold, a line each (``seed 1: expected ...``), and the node running last; empty if it held."""
        lines = [f"{s.seed}: {f}" if s.seed else f for s in self.seeds for f in s.failures]
        lines += [f"{s.seed}: {s.running} was running last" for s in self.seeds if s.failures and s.running]
        return "\n".join(lines)


@dataclass
class Coverage:
    """Which statuses each node of a mission returned across its scenarios' runs.

    Attributes:
        nodes: The mission's tree.
        seen: By node id, the statuses some run saw it return.
        statuses: By node type, the statuses a node of it can return (its type says: a condition answers
            SUCCESS or FAILURE, a beep is never RUNNING, a wait never fails); a type not in it, all three.
    """

    nodes: list[NodeInfo]
    seen: dict[int, set[str]] = field(default_factory=dict)
    statuses: dict[str, tuple[str, ...]] = field(default_factory=dict)
    _possible: dict[int, tuple[str, ...]] = field(default_factory=dict, init=False, repr=False)

    def possible(self, node: NodeInfo) -> tuple[str, ...]:
        """The statuses ``node`` can return: what its type says, and what its children let it.

        A leaf returns what its type declares (a condition answers SUCCESS or FAILURE, a beep is never
        RUNNING). A composite or a decorator returns what its children's statuses lead to: a sequence of
        conditions is never RUNNING, a sequence of things that never fail never fails, a ``repeat``
        forever never succeeds.
        """
        if not self._possible:
            for each in reversed(self.nodes):  # children come after their parents
                self._possible[each.id] = self._of(each)
        return self._possible.get(node.id) or self._of(node)

    def _own(self, node: NodeInfo) -> set[str]:
        if node.type in self.statuses:
            return set(self.statuses[node.type])
        return {"SUCCESS", "FAILURE"} if node.category == "condition" else set(STATUSES)

    def _of(self, node: NodeInfo) -> tuple[str, ...]:
        own = self._own(node)
        kids = [set(self._possible.get(n.id, ())) for n in self.nodes if n.parent == node.id]
        if not kids or node.category not in ("composite", "decorator", "reference"):
            return tuple(s for s in STATUSES if s in own)
        every = {s: all(s in k for k in kids) for s in STATUSES}
        some = {s: any(s in k for k in kids) for s in STATUSES}
        kind = node.type
        if kind in ("sequence", "while"):
            can = {"SUCCESS": every["SUCCESS"], "FAILURE": some["FAILURE"], "RUNNING": some["RUNNING"]}
        elif kind in ("selector", "fallback"):
            can = {"SUCCESS": some["SUCCESS"], "FAILURE": every["FAILURE"], "RUNNING": some["RUNNING"]}
        elif kind == "parallel":
            success = every["SUCCESS"] if node.params.get("policy", "all") == "all" else some["SUCCESS"]
            can = {"SUCCESS": success, "FAILURE": some["FAILURE"], "RUNNING": some["RUNNING"] or len(kids) > 1}
        elif kind == "repeat":
            times = node.params.get("times")
            can = {"SUCCESS": times is not None and some["SUCCESS"], "FAILURE": some["FAILURE"],
                   "RUNNING": some["RUNNING"] or some["SUCCESS"] and (times is None or times > 1)}  # fmt: skip
        elif kind == "retry":
            again = some["FAILURE"] and node.params.get("attempts", 1) > 1
            can = {"SUCCESS": some["SUCCESS"], "FAILURE": some["FAILURE"], "RUNNING": some["RUNNING"] or again}
        elif kind == "timeout":
            can = {
                "SUCCESS": some["SUCCESS"],
                "FAILURE": some["FAILURE"] or some["RUNNING"],
                "RUNNING": some["RUNNING"],
            }
        elif kind == "invert":
            can = {"SUCCESS": some["FAILURE"], "FAILURE": some["SUCCESS"], "RUNNING": some["RUNNING"]}
        elif kind == "force_success":
            can = {"SUCCESS": some["SUCCESS"] or some["FAILURE"], "FAILURE": False, "RUNNING": some["RUNNING"]}
        elif kind == "force_failure":
            can = {"SUCCESS": False, "FAILURE": some["SUCCESS"] or some["FAILURE"], "RUNNING": some["RUNNING"]}
        elif kind in ("once", "subtree", "random"):
            can = some
        else:  # a plugin's composite or decorator: what its type declares
            can = {s: True for s in STATUSES}
        return tuple(s for s in STATUSES if can[s] and s in own)

    @property
    def pairs(self) -> tuple[int, int]:
        """How many node x status pairs were seen, of how many can occur."""
        seen = sum(len(self.seen.get(n.id, set()) & set(self.possible(n))) for n in self.nodes)
        return seen, sum(len(self.possible(n)) for n in self.nodes)

    @property
    def percent(self) -> float:
        """The share of the node x status pairs seen, in percent."""
        seen, possible = self.pairs
        return 100.0 * seen / possible if possible else 100.0


def run_scenario(tests: ScenarioFile, scenario: Scenario, coverage: Coverage | None = None) -> ScenarioOutcome:
    """Runs one scenario on each of its seeds and checks what it expects; adds what its nodes did to ``coverage``."""
    seeds = []
    simulated_s = 0.0
    started_s = cpu_time_s()
    for seed in scenario.exercise.seeds:
        outcome = _run_seed(tests, scenario, seed, coverage)
        simulated_s += outcome.time_s
        seeds.append(outcome)
    return ScenarioOutcome(str(tests.path), scenario.name, scenario.line, seeds, simulated_s, cpu_time_s() - started_s)


def _run_seed(tests: ScenarioFile, scenario: Scenario, seed: Seed, coverage: Coverage | None) -> SeedOutcome:
    watch = NodeWatch()
    try:
        more = {"battery": scenario.battery} if scenario.battery is not None else None
        facts = run_seed(
            scenario.exercise,
            tests.spec,
            seed,
            watchers=[watch],
            emulator=more,
            script=scenario.script,
            start=scenario.start,
        )
    except LinkError as err:
        return SeedOutcome(seed.label, "no run", 0.0, [f"no run: the link failed before the mission started ({err})"])
    if facts.outcome == INTERRUPTED:  # Ctrl-C: the run was stopped; so is the rest
        raise KeyboardInterrupt
    if coverage is not None:
        for node in watch.changes:
            coverage.seen.setdefault(node, set()).update(watch.seen(node))
    failures = []
    allowed = scenario.outcomes or ENDED_AS_WRITTEN
    if facts.outcome not in allowed:
        said = " or ".join(f"'{outcome}'" for outcome in allowed)
        why = f": {facts.reason}" if facts.reason and facts.outcome not in (SUCCEEDED, TIME_LIMIT) else ""
        failures.append(f"expected the outcome {said}, but the mission {_ended(facts.outcome)}{why}")
    if scenario.within_s is not None:
        if facts.outcome not in (SUCCEEDED, FAILED):
            ended = _ended(facts.outcome)
            failures.append(
                f"expected it to end by itself within {scenario.within_s:g} s, but it {ended} at {facts.time_s:g} s"
            )
        elif facts.time_s > scenario.within_s + 1e-9:
            failures.append(f"expected it to end within {scenario.within_s:g} s, but it ended at {facts.time_s:g} s")
    for criterion, verdict in zip(scenario.exercise.criteria, verdicts_of(scenario.exercise, seed, facts), strict=True):
        if not verdict.held:
            failures.append(f"expected {criterion.shown}: {verdict.line}")
    failures += _measured(scenario, facts)
    for check in scenario.nodes:
        held, instead = watch.holds(check, tests.paths)
        if not held:
            failures.append(f"expected {check.words}, but {instead}")
    if facts.left_going:
        failures.append("the run ended with the robot still told to drive: the stop at the end never reached it")
    running = facts.running_at(facts.time_s) if failures else ""
    return SeedOutcome(seed.label, facts.outcome, round(facts.time_s, 2), failures, running)


def _measured(scenario: Scenario, facts: RunFacts) -> list[str]:
    """What the run's beeps, distance and servo moves did where the scenario expects otherwise, a line each."""
    failures = []
    audible = facts.sounded
    if scenario.beeps is not None and len(audible) != scenario.beeps:
        silent = len(facts.beeps) - len(audible)
        also = f" (and {plural(silent, 'silent one')}, at volume 0)" if silent else ""
        failures.append(
            f"expected {plural(scenario.beeps, 'beep')}, but it beeped {plural(len(audible), 'time')}{also}"
        )
    if scenario.beep_volume is not None:
        other = next((beep for beep in audible if beep.volume != scenario.beep_volume), None)
        if other is not None:
            failures.append(
                f"expected every beep at volume {scenario.beep_volume}, but it beeped at volume {other.volume} "
                f"at {max(0.0, round(other.time_s, 3)):g} s"
            )
    if scenario.distance_mm is not None:
        low, high = scenario.distance_mm
        if not low - 1e-6 <= facts.distance_mm <= high + 1e-6:
            failures.append(
                f"expected it to drive {low:,.0f} to {high:,.0f} mm in all, but it drove {facts.distance_mm:,.0f} mm"
            )
    for servo, angles in scenario.servos:
        sent = [round(angle) for _, at, angle in facts.servo_moves if at == servo]
        if sent != list(angles):
            said = ", ".join(f"{a:g}" for a in sent) if sent else "none"
            failures.append(f"expected servo {servo} sent to {list(angles)}, but it was sent to [{said}]")
    return failures


@dataclass
class MutationScore:
    """How many of a mission's mutants its scenarios caught (see :mod:`autonomy.scenarios.mutants`).

    Attributes:
        caught: The changes some scenario failed on.
        survived: The changes every scenario passed: "your tests pass even when ...".
    """

    caught: list[str] = field(default_factory=list)
    survived: list[str] = field(default_factory=list)

    @property
    def percent(self) -> float:
        """The share of the mutants caught, in percent (100 when there are none)."""
        total = len(self.caught) + len(self.survived)
        return 100.0 * len(self.caught) / total if total else 100.0


def mutation_score(tests: ScenarioFile) -> MutationScore:
    """Runs the file's scenarios on each mutant of its mission, up to the first that fails; which were caught."""
    from dataclasses import replace

    from autonomy.scenarios.mutants import mutants

    score = MutationScore()
    for mutant in mutants(tests.spec):
        mutated = replace(tests, spec=mutant.spec)
        try:
            caught = any(not run_scenario(mutated, scenario).passed for scenario in tests.scenarios)
        except Exception:  # noqa: BLE001 - a mutant its run cannot take fails its tests: caught
            caught = True
        (score.caught if caught else score.survived).append(mutant.change)
    return score


def _guarded(tests: ScenarioFile, scenario: Scenario) -> tuple[ScenarioOutcome, dict[int, set[str]]]:
    """One scenario run, and the statuses its nodes returned; a plugin's error (``sys.exit`` too) is its failure."""
    coverage = Coverage(tests.nodes, statuses=tests.statuses)
    try:
        return run_scenario(tests, scenario, coverage), coverage.seen
    except KeyboardInterrupt:
        raise
    except BaseException as err:  # noqa: BLE001 - whatever the author's Python did (sys.exit too): this scenario's failure
        why = f"the run stopped with {type(err).__name__}: {err}"
        return ScenarioOutcome(
            str(tests.path), scenario.name, scenario.line, [SeedOutcome("", "", 0.0, [why])], 0.0
        ), {}


#: In a worker process: the scenario files read there, by path (each read once, its mission's plugins with it).
_READ: dict[str, ScenarioFile] = {}


def _in_worker(path: str, index: int) -> tuple[ScenarioOutcome, dict[int, set[str]]]:
    """Scenario ``index`` of the file at ``path``, run in a worker process (the file read there once)."""
    from autonomy.scenarios.files import load_scenarios

    if path not in _READ:
        _READ[path] = load_scenarios(path)
    tests = _READ[path]
    return _guarded(tests, tests.scenarios[index])


def _worker_start(main_pid: int) -> None:
    """In a worker process: Ctrl-C is for the command (it ends the workers), and a worker whose command is gone ends."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    end_with(main_pid)


def _ended_why(tests: ScenarioFile, k: int) -> tuple[ScenarioOutcome, dict[int, set[str]]]:
    """The outcome of a scenario whose process ended under it (``os._exit`` in a plugin, or killed)."""
    scenario = tests.scenarios[k]
    why = "the scenario's process ended while it ran (a plugin's os._exit, or killed): no outcome"
    return ScenarioOutcome(str(tests.path), scenario.name, scenario.line, [SeedOutcome("", "", 0.0, [why])], 0.0), {}


def _pool(jobs: int) -> ProcessPoolExecutor:
    context = multiprocessing.get_context("forkserver")
    return ProcessPoolExecutor(max_workers=jobs, mp_context=context, initializer=_worker_start, initargs=(os.getpid(),))


def _end_pool(pool: ProcessPoolExecutor) -> None:
    """Ends a pool's workers now, whatever they are doing (a plugin may sleep for ever)."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        if process.is_alive():
            process.kill()
    for process in processes:
        process.join(5)


def run_all(
    files: list[ScenarioFile], jobs: int = 1
) -> Iterator[tuple[ScenarioFile, ScenarioOutcome, dict[int, set[str]]]]:
    """Every scenario of ``files``, in their order: its file, its outcome and the statuses its nodes returned.

    With ``jobs`` above 1, or a mission with plugins (whose Python may end its process), the scenarios run
    in worker processes (each reads the files itself, as ``autonomy test`` read them), and come back in the
    files' order all the same. A worker that ends under its scenario fails that scenario alone: when the
    pool breaks, the scenarios it held run again one at a time, each in a pool of its own, to tell which.
    Ctrl-C ends the workers at once and raises ``KeyboardInterrupt``.
    """
    work = [(tests, k) for tests in files for k in range(len(tests.scenarios))]
    apart = jobs > 1 and len(work) > 1 or any(tests.spec.plugins for tests in files)
    if not apart:
        for tests, k in work:
            yield (tests, *_guarded(tests, tests.scenarios[k]))
        return
    pool = _pool(max(1, min(jobs, len(work))))
    try:
        futures = [pool.submit(_in_worker, str(tests.path), k) for tests, k in work]
        for index, ((tests, k), future) in enumerate(zip(work, futures, strict=True)):
            try:
                yield (tests, *future.result())
            except BrokenProcessPool:
                _end_pool(pool)
                for tests, k in work[index:]:  # one at a time, in a pool of its own: which one ended its process
                    pool = _pool(1)
                    try:
                        yield (tests, *pool.submit(_in_worker, str(tests.path), k).result())
                    except BrokenProcessPool:
                        yield (tests, *_ended_why(tests, k))
                    finally:
                        _end_pool(pool)
                return
    finally:
        _end_pool(pool)
