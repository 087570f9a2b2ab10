"""``autonomy test``: a mission's scenario files run, a line a scenario, and which of its nodes' statuses none saw."""

from __future__ import annotations

import argparse
import json
import os
import signal
import sys
from pathlib import Path
from typing import Any

from autonomy.cli.common import (
    EXIT_FAILED,
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_USAGE,
    _bounded,
    _fail,
    _interrupt,
    _problems,
    _shown,
)
from autonomy.words import plural

#: The simulated seconds the scenarios may take in all, at most, past which they run a process a core by default.
PARALLEL_FROM_S = 600.0


def cmd_test(args: argparse.Namespace) -> int:
    """Finds the scenario files, runs every scenario on each of its seeds, and says which held."""
    from autonomy.scenarios import Coverage, ScenariosInvalid, find_scenario_files, load_scenarios
    from autonomy.scenarios.running import ScenarioOutcome, run_all

    paths = find_scenario_files(args.paths or ["."])
    missing = [p for p in paths if not p.is_file()]
    if missing:
        return _fail(f"{missing[0]}: no such scenario file (a NAME.test.yaml, or a folder holding some)", EXIT_USAGE)
    if not paths:
        where = " ".join(args.paths or ["."])
        return _fail(
            f"no scenario files (NAME.test.yaml beside NAME.yaml, or a mission's tests: list) under {where}", EXIT_USAGE
        )
    files = []
    for path in paths:
        try:
            files.append(load_scenarios(path))
        except ScenariosInvalid as err:
            return _problems(err.problems)
    refused = _outputs_refused(args, files)
    if refused:
        return _fail(refused, EXIT_USAGE)
    outcomes: list[ScenarioOutcome] = []
    coverages: dict[Path, tuple[Any, Any]] = {}  # a mission's coverage, whichever of its files its scenarios are in
    for tests in files:
        coverages.setdefault(_mission_key(tests), (tests, Coverage(tests.nodes, statuses=tests.statuses)))
    # a process a core pays for its start when there is much to run: over ten simulated minutes at most
    most_s = sum(s.exercise.time_limit_s * len(s.exercise.seeds) for tests in files for s in tests.scenarios)
    jobs = args.jobs or ((os.cpu_count() or 1) if most_s > PARALLEL_FROM_S else 1)
    total = sum(len(tests.scenarios) for tests in files)
    signal.signal(signal.SIGTERM, _interrupt)  # as Ctrl-C: the workers ended, the run said interrupted
    signal.signal(signal.SIGINT, _interrupt)  # Ctrl-C as the command's (Interrupted), never a plugin's problem
    try:
        for tests, outcome, seen in run_all(files, jobs):
            for node, statuses in seen.items():
                coverages[_mission_key(tests)][1].seen.setdefault(node, set()).update(statuses)
            outcomes.append(outcome)
            if not args.json:
                _say(outcome)
    except KeyboardInterrupt:  # Ctrl-C: the runs under way were stopped, their workers ended
        print(f"autonomy: interrupted after {len(outcomes)} of {plural(total, 'scenario')}", file=sys.stderr)
        return EXIT_INTERRUPTED
    took_s = sum(o.cpu_s for o in outcomes)
    failed = sum(not o.passed for o in outcomes)
    written = [
        (args.junit, lambda: junit_xml(outcomes)),
        (args.html, lambda: coverage_html(list(coverages.values()))),
        (args.cobertura, lambda: cobertura_xml(list(coverages.values()), Path.cwd())),
    ]
    for path, made in written:
        if path:
            try:
                Path(path).write_text(made(), encoding="utf-8")
            except OSError as err:
                return _fail(f"cannot write {path}: {err.strerror or err}", EXIT_USAGE)
    report = as_json(outcomes, list(coverages.values()))
    if not args.json:
        runs = sum(len(o.seeds) for o in outcomes)
        simulated_s = sum(o.simulated_s for o in outcomes)
        print(
            f"{plural(len(outcomes), 'scenario')}: {len(outcomes) - failed} passed, {failed} failed "
            f"({plural(runs, 'run')}, {simulated_s:,.1f} simulated s in {took_s:.2f} s of CPU time)"
        )
        for tests, coverage in coverages.values():
            seen, possible = coverage.pairs
            print(
                _shown(
                    f"coverage of {tests.mission.name}: {seen} of {possible} node statuses seen "
                    f"({_percent(coverage.percent)})"
                )
            )
            if args.coverage:
                print(coverage_table(coverage))
    try:
        scores = _mutation(args, files, outcomes) if args.mutate else []
    except KeyboardInterrupt:  # Ctrl-C while the mutants run: the scenarios' results stand, said above
        print("autonomy: interrupted while trying the mutants: no mutation score", file=sys.stderr)
        return EXIT_INTERRUPTED
    if args.json and scores:
        report["mutation"] = [
            {"file": str(tests.path), "mission": str(tests.mission), "percent": round(score.percent, 1),
             "caught": score.caught, "survived": score.survived}
            for tests, score in scores
        ]  # fmt: skip
    if args.json:
        json.dump(report, sys.stdout, indent=1)
        sys.stdout.write("\n")
    below = [c for _, c in coverages.values() if args.fail_under is not None and c.percent < args.fail_under]
    if below and not args.json:
        names = ", ".join(
            f"{tests.mission.name} ({_percent(c.percent)})" for tests, c in coverages.values() if c in below
        )
        print(_shown(f"coverage under {args.fail_under:g}%: {names}"), file=sys.stderr)
    return EXIT_FAILED if failed or below else EXIT_OK


def _mission_key(tests: Any) -> Path:
    """The mission a scenario file tests, as one path whatever the name it was given by."""
    return tests.mission.resolve()


def _by_mission(files: list[Any]) -> list[Any]:
    """The files as one a mission: a mission's scenario file and its own tests: list, their scenarios together."""
    from dataclasses import replace

    merged: dict[Path, Any] = {}
    for tests in files:
        key = _mission_key(tests)
        merged[key] = (
            replace(merged[key], scenarios=[*merged[key].scenarios, *tests.scenarios]) if key in merged else tests
        )
    return list(merged.values())


def _outputs_refused(args: argparse.Namespace, files: list[Any]) -> str:
    """Why ``--junit``, ``--html`` or ``--cobertura`` cannot be written (empty: they can), said before anything runs.

    None may be a file the run reads (a scenario file or its mission), nor another one of them; each must be
    a file that can be written now, not only after the scenarios have run.
    """
    read = {path.resolve() for tests in files for path in (tests.path, tests.mission)}
    written: dict[Path, str] = {}
    for option, given in (("--junit", args.junit), ("--html", args.html), ("--cobertura", args.cobertura)):
        if given is None:
            continue
        if not given.strip():
            return f"{option} needs a file's name"
        path = Path(given).resolve()
        if path in read:
            return f"{option} {given} is a file the tests read: give a file of its own"
        if path in written:
            return f"{option} and {written[path]} are the same file: give each its own"
        written[path] = option
        try:
            with open(path, "a", encoding="utf-8"):  # can be written (made, if it was not there)
                pass
        except OSError as err:
            return f"cannot write {given}: {err.strerror or err}"
    return ""


def _mutation(args: argparse.Namespace, files: list[Any], outcomes: list[Any]) -> list[tuple[Any, Any]]:
    """Each file's mutation score (its scenarios must pass first); said as lines unless ``--json``."""
    from autonomy.scenarios.running import mutation_score

    if any(not o.passed for o in outcomes):
        if not args.json:
            print("mutants: not tried, as a scenario fails already (a mutant is caught when a scenario fails)")
        return []
    scores = []
    for tests in _by_mission(files):  # a mutant is caught when any scenario of its mission, in any file, fails
        score = mutation_score(tests)
        scores.append((tests, score))
        if not args.json:
            total = len(score.caught) + len(score.survived)
            caught = f"{len(score.caught)} of {total} caught ({_percent(score.percent)})"
            print(_shown(f"mutants of {tests.mission.name}: {caught}"))
            for change in score.survived:
                print(_shown(f"  your tests pass even when {change}"))
    return scores


def _say(outcome: Any) -> None:
    """One line for a scenario; under a failed one, a line for each thing that did not hold, on each seed."""
    seeds = len(outcome.seeds)
    head = f"{outcome.file}:{outcome.line}: {outcome.name}"
    if outcome.passed:
        print(
            _shown(f"ok    {head} ({seeds} {'seed' if seeds == 1 else 'seeds'}, {outcome.simulated_s:.1f} simulated s)")
        )
        return
    print(_shown(f"FAIL  {head}"))
    for seed in outcome.seeds:
        for failure in seed.failures:
            where = f"{seed.seed}: " if seed.seed else ""
            print(_shown(f"      {where}{failure}"))
        if seed.failures and seed.running:
            print(
                _shown(
                    f"      {seed.seed}: the mission ended at {seed.time_s:g} s ({seed.outcome}), "
                    f"{seed.running} running last"
                )
            )


def _percent(value: float) -> str:
    """A share as it is said: ``62.5%``, ``88%`` (one decimal at most, and none when it is whole)."""
    return f"{round(value, 1):g}%"


def coverage_table(coverage: Any) -> str:
    """The tree, a node a line, with each status it can return marked seen (+) or never seen (-)."""
    from autonomy.scenarios.files import STATUSES

    depth: dict[int, int] = {}
    lines = []
    for node in coverage.nodes:
        depth[node.id] = 0 if node.parent is None else depth[node.parent] + 1
        seen = coverage.seen.get(node.id, set())
        possible = coverage.possible(node)  # a column each status, blank where the type cannot return it
        marks = "  ".join(f"{'+' if s in seen else '-'}{s}" if s in possible else " " * (len(s) + 1) for s in STATUSES)
        lines.append(f"  {marks:32} {'  ' * depth[node.id]}{_shown(node.name)} ({node.type})")
    return "\n".join(lines)


def as_json(outcomes: list[Any], coverages: list[tuple[Any, Any]]) -> dict[str, Any]:
    """What ``--json`` prints: each scenario with its seeds, and each mission's coverage."""
    from autonomy.scenarios.files import node_paths

    return {
        "passed": sum(o.passed for o in outcomes),
        "failed": sum(not o.passed for o in outcomes),
        "scenarios": [
            {
                "file": o.file,
                "line": o.line,
                "name": o.name,
                "passed": o.passed,
                "seeds": [
                    {
                        "seed": s.seed,
                        "outcome": s.outcome,
                        "time_s": s.time_s,
                        "failures": s.failures,
                        "running": s.running,
                    }
                    for s in o.seeds
                ],
            }
            for o in outcomes
        ],
        "coverage": [
            {
                "file": str(tests.path),
                "mission": str(tests.mission),
                "percent": round(coverage.percent, 1),
                "seen": coverage.pairs[0],
                "possible": coverage.pairs[1],
                "nodes": [
                    {
                        "id": node.id,
                        "path": path,
                        "type": node.type,
                        "seen": sorted(coverage.seen.get(node.id, set()) & set(coverage.possible(node))),
                        "never": sorted(set(coverage.possible(node)) - coverage.seen.get(node.id, set())),
                    }
                    for node, path in zip(tests.nodes, node_paths(tests.nodes), strict=True)
                ],
            }
            for tests, coverage in coverages
        ],
    }


def junit_xml(outcomes: list[Any]) -> str:
    """The scenarios as JUnit XML: a test suite a file, a test case a scenario, a failure for each that failed."""
    import xml.etree.ElementTree as ET

    suites = ET.Element("testsuites", tests=str(len(outcomes)), failures=str(sum(not o.passed for o in outcomes)))
    by_file: dict[str, list[Any]] = {}
    for outcome in outcomes:
        by_file.setdefault(outcome.file, []).append(outcome)
    for file, ones in by_file.items():
        suite = ET.SubElement(
            suites, "testsuite", name=file, tests=str(len(ones)), failures=str(sum(not o.passed for o in ones))
        )
        for outcome in ones:
            case = ET.SubElement(suite, "testcase", classname=file, name=outcome.name, time=f"{outcome.cpu_s:.3f}")
            if not outcome.passed:
                lines = [f"{s.seed}: {f}" if s.seed else f for s in outcome.seeds for f in s.failures]
                failure = ET.SubElement(case, "failure", message=_xml_text(lines[0]))
                failure.text = _xml_text("\n".join(lines))
    return ET.tostring(suites, encoding="unicode", xml_declaration=True) + "\n"


def cobertura_xml(coverages: list[tuple[Any, Any]], base: Path) -> str:
    """Each mission's coverage as Cobertura XML, which CI tools (GitLab, Jenkins, Azure) read and show by line.

    A mission file is a class, a line of it that holds nodes a line, and its node statuses its branches: a line
    is hit when one of its nodes ran, and its ``condition-coverage`` is the share of the statuses its nodes can
    return that some run saw. Files are named from ``base`` (the working folder) where they are under it.
    """
    import xml.etree.ElementTree as ET

    from autonomy import __version__

    def rate(part: int, whole: int) -> str:
        return f"{part / whole:.4f}" if whole else "1"

    def name_of(file: str) -> str:
        path = Path(file).resolve()
        return str(path.relative_to(base.resolve())) if path.is_relative_to(base.resolve()) else str(path)

    by_file: dict[str, dict[int, list[tuple[int, int]]]] = {}
    for tests, coverage in coverages:
        for node in coverage.nodes:
            if not node.line:
                continue
            possible = set(coverage.possible(node))
            seen = len(coverage.seen.get(node.id, set()) & possible)
            lines = by_file.setdefault(name_of(node.file or str(tests.mission)), {})
            lines.setdefault(node.line, []).append((seen, len(possible)))
    totals = {"lines": 0, "hit": 0, "branches": 0, "seen": 0}
    classes = []
    for file, lines in sorted(by_file.items()):
        element = ET.Element("class", name=Path(file).stem, filename=file, complexity="0")
        ET.SubElement(element, "methods")
        listed = ET.SubElement(element, "lines")
        hit = branches = seen_all = 0
        for number, nodes in sorted(lines.items()):
            seen, possible = sum(s for s, _ in nodes), sum(p for _, p in nodes)
            share = f"{100 * seen // possible if possible else 100}% ({seen}/{possible})"
            ET.SubElement(
                listed, "line", number=str(number), hits=str(seen), branch="true", **{"condition-coverage": share}
            )
            hit += seen > 0
            branches, seen_all = branches + possible, seen_all + seen
        element.set("line-rate", rate(hit, len(lines)))
        element.set("branch-rate", rate(seen_all, branches))
        classes.append(element)
        totals["lines"] += len(lines)
        totals["hit"] += hit
        totals["branches"] += branches
        totals["seen"] += seen_all
    root = ET.Element(
        "coverage",
        {
            "line-rate": rate(totals["hit"], totals["lines"]),
            "branch-rate": rate(totals["seen"], totals["branches"]),
            "lines-covered": str(totals["hit"]),
            "lines-valid": str(totals["lines"]),
            "branches-covered": str(totals["seen"]),
            "branches-valid": str(totals["branches"]),
            "complexity": "0",
            "version": f"autonomy {__version__}",
            "timestamp": "0",
        },
    )
    ET.SubElement(ET.SubElement(root, "sources"), "source").text = str(base.resolve())
    package = ET.SubElement(
        ET.SubElement(root, "packages"),
        "package",
        {"name": "missions", "line-rate": root.get("line-rate", "1"), "branch-rate": root.get("branch-rate", "1"),
         "complexity": "0"},
    )  # fmt: skip
    ET.SubElement(package, "classes").extend(classes)
    text = ET.tostring(root, encoding="unicode")
    doctype = "<!DOCTYPE coverage SYSTEM 'http://cobertura.sourceforge.net/xml/coverage-04.dtd'>"
    return f"<?xml version='1.0' encoding='utf-8'?>\n{doctype}\n{text}\n"


def _xml_text(text: str) -> str:
    """``text`` with the characters XML 1.0 cannot hold (control characters but tab and newline) as U+FFFD."""
    return "".join(
        c if c in "\t\n\r" or (" " <= c and c not in "\ufffe\uffff" and not "\ud800" <= c <= "\udfff") else "\ufffd"
        for c in text
    )


def add_parsers(sub: Any) -> None:
    """Adds ``autonomy test`` to the command line's subparsers."""
    parser = sub.add_parser(
        "test", help="run a mission's scenario files (NAME.test.yaml beside NAME.yaml): each scenario a line"
    )
    parser.add_argument(
        "paths", nargs="*", metavar="PATH", help="scenario files, or folders searched for them (default: here)"
    )
    parser.add_argument("--json", action="store_true", help="print the results as JSON, not lines")
    parser.add_argument("--junit", metavar="FILE", help="also write the results as JUnit XML, for CI")
    parser.add_argument(
        "--coverage", action="store_true", help="list each node with the statuses some scenario saw it return"
    )
    parser.add_argument(
        "-j",
        "--jobs",
        type=_bounded(int, 1, 256, "a number of processes"),
        metavar="N",
        help="run N scenarios at once, each in a process of its own (default: one a core, when they may take "
        "more than 10 simulated minutes in all)",
    )
    parser.add_argument(
        "--mutate",
        action="store_true",
        help="then change the mission a little, one thing at a time, and say which changes no scenario notices",
    )
    parser.add_argument(
        "--html", metavar="FILE", help="also write each tree drawn with its nodes filled by coverage, one offline page"
    )
    parser.add_argument(
        "--cobertura",
        metavar="FILE",
        help="also write the coverage as Cobertura XML, by mission file and line, for CI tools that show it",
    )
    parser.add_argument(
        "--fail-under",
        type=_bounded(float, 0, 100, "a percentage"),
        metavar="PERCENT",
        help="fail (exit 1) when a mission's node statuses seen are under PERCENT",
    )
    parser.set_defaults(func=cmd_test)


#: A node's coverage as its box is filled on the page: every status it can return seen, some, none.
COVERAGE_FILLS = {"full": "#c8e6c9", "part": "#ffe0b2", "none": "#ffcdd2"}


def coverage_html(coverages: list[tuple[Any, Any]]) -> str:
    """One offline page: each mission's tree, each node's box filled by how many of its statuses some run saw.

    Below each tree, the same as a table (each status seen or never seen, in words), for those who do not
    tell the fills apart.
    """
    from html import escape

    from autonomy.scenarios.files import node_paths
    from autonomy.views.lines import printable
    from autonomy.views.treesvg import svg_tree

    style = "".join(f".{kind} rect{{fill:{fill}}}" for kind, fill in COVERAGE_FILLS.items())
    parts = [
        '<!doctype html>\n<html lang="en"><head><meta charset="utf-8">',
        "<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; style-src 'unsafe-inline'\">",
        f"<title>Coverage of the missions' trees</title><style>body{{font-family:sans-serif;margin:1em}}"
        f"table{{border-collapse:collapse}}td,th{{border:1px solid #999;padding:2px 6px;text-align:left}}"
        f"svg{{max-width:100%;height:auto}}{style}</style></head><body>",
        "<h1>Coverage of the missions' trees</h1>",
        "<p>Each node's box: green, every status it can return was seen in some scenario's run; orange, some; "
        "red, none (it never ran). The table under each tree says which.</p>",
    ]
    for number, (tests, coverage) in enumerate(coverages, start=1):
        seen_pairs, possible = coverage.pairs
        drawn = svg_tree(tests.nodes, f"{tests.mission.name}: coverage", legend=False)
        for node in tests.nodes:  # each tree's nodes told apart from the next tree's: m2-node-3
            got = coverage.seen.get(node.id, set()) & set(coverage.possible(node))
            kind = "full" if len(got) == len(coverage.possible(node)) else "part" if got else "none"
            drawn = drawn.replace(
                f'<g class="node" id="node-{node.id}"', f'<g class="node {kind}" id="m{number}-node-{node.id}"'
            )
        parts.append(f"<h2>{escape(printable(tests.mission.name))}</h2>")
        parts.append(f"<p>{seen_pairs} of {possible} node statuses seen ({_percent(coverage.percent)}), "
                     f"by {escape(printable(tests.path.name))}.</p>")  # fmt: skip
        parts.append(f'<figure>{drawn}<figcaption>the tree of {escape(printable(tests.mission.name))}, '
                     "each box filled by its coverage</figcaption></figure>")  # fmt: skip
        parts.append(f'<table id="m{number}"><tr><th>node</th><th>type</th><th>seen</th><th>never seen</th></tr>')
        for node, path in zip(tests.nodes, node_paths(tests.nodes), strict=True):
            got = coverage.seen.get(node.id, set())
            never = [s for s in coverage.possible(node) if s not in got]
            parts.append(
                f"<tr><td>{escape(printable(path))}</td><td>{escape(node.type)}</td>"
                f"<td>{', '.join(s for s in coverage.possible(node) if s in got) or 'nothing'}</td>"
                f"<td>{', '.join(never) or '-'}</td></tr>"
            )
        parts.append("</table>")
    parts.append("</body></html>\n")
    return "\n".join(parts)
