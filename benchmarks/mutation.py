"""The mutation score of the last `mutmut run` (see `make mutation`), for the README.

Counts, for each of the five mutated modules, the mutants the tests caught (killed, or ended
by mutmut's time-out: a mutant that makes a run hang is caught too) against every mutant
that changes more than message text. A mutant that only rewrites a string literal (an error
message, a hint) is counted apart: the wording of messages is checked where it matters, by
tests that read them, not mutant by mutant.

Usage: python benchmarks/mutation.py [--survivors]   (from the repository's root)
"""

from __future__ import annotations

import io
import sys
import tokenize
from collections import Counter, defaultdict

from mutmut.__main__ import SourceFileMutationData, get_diff_for_mutant, status_by_exit_code, walk_mutatable_files

CAUGHT = ("killed", "timeout", "caught by type check")


def _code_tokens(lines: list[str]) -> list[str]:
    """The tokens of ``lines`` with every string literal made the same, so only code differences remain."""
    try:
        tokens = list(tokenize.generate_tokens(io.StringIO("\n".join(lines) + "\n").readline))
    except (tokenize.TokenError, IndentationError, SyntaxError):
        return ["<untokenizable>", *lines]
    kinds = (tokenize.NL, tokenize.NEWLINE, tokenize.INDENT, tokenize.DEDENT, tokenize.COMMENT)
    fstring = {
        getattr(tokenize, name)
        for name in ("FSTRING_START", "FSTRING_MIDDLE", "FSTRING_END")
        if hasattr(tokenize, name)
    }
    return [
        "<str>" if t.type == tokenize.STRING or t.type in fstring else t.string for t in tokens if t.type not in kinds
    ]


def message_only(diff: str) -> bool:
    """True when a mutant's diff changes nothing but the text inside string literals."""
    removed = [line[1:].strip() for line in diff.splitlines() if line.startswith("-") and not line.startswith("---")]
    added = [line[1:].strip() for line in diff.splitlines() if line.startswith("+") and not line.startswith("+++")]
    return bool(removed) and _code_tokens(removed) == _code_tokens(added)


def main() -> None:
    show_survivors = "--survivors" in sys.argv
    totals: Counter = Counter()
    by_module: dict[str, Counter] = defaultdict(Counter)
    survivors: list[str] = []
    for path in walk_mutatable_files():
        data = SourceFileMutationData(path=path)
        data.load()
        for name, code in data.exit_code_by_key.items():
            status = status_by_exit_code[code]
            if status in CAUGHT:
                kind = "caught"
            elif status in ("not checked", "skipped"):
                kind = "not run"
            elif message_only(get_diff_for_mutant(name, path=path)):
                kind = "message only"
            else:
                kind = "survived"
                survivors.append(name)
            by_module[str(path)][kind] += 1
            totals[kind] += 1
    if not totals:
        print('no results: run "mutmut run" first')
        return

    def score(counts: Counter) -> str:
        judged = counts["caught"] + counts["survived"]
        return f"{counts['caught'] / judged:.1%}" if judged else "-"

    print(f"{'module':32} {'caught':>7} {'survived':>9} {'message only':>13} {'not run':>8} {'score':>7}")
    for module, counts in sorted(by_module.items()):
        print(
            f"{module:32} {counts['caught']:7} {counts['survived']:9} {counts['message only']:13} "
            f"{counts['not run']:8} {score(counts):>7}"
        )
    print(
        f"{'all':32} {totals['caught']:7} {totals['survived']:9} {totals['message only']:13} "
        f"{totals['not run']:8} {score(totals):>7}"
    )
    if show_survivors:
        for name in survivors:
            print(name)


if __name__ == "__main__":
    main()
