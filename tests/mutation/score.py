"""The mutation score, from mutmut's results and the committed list of equivalent mutants.

Run from the project root after `mutmut run` (docs/mutation.md):

    python tests/mutation/score.py               # the table per module, as in docs/mutation.md
    python tests/mutation/score.py --survivors   # every mutant not killed and not listed as equivalent

mutmut keeps one verdict per mutant in mutants/<source>.meta. Here killed means killed by a
test, by a timeout or by the type check; an *equivalent* mutant is one that no test can tell
from the original, listed with its reason in tests/mutation/equivalent.toml; *not killed* is
every other decided mutant (survived, suspicious, reached by no test); *not run* has no
verdict yet. The score is killed / (killed + not killed). A mutant listed as equivalent that a
test now kills is reported, so the list cannot go stale unseen.
"""
from __future__ import annotations

import argparse
import json
import sys
import tomllib
from collections import Counter
from pathlib import Path

EQUIVALENT_FILE = Path(__file__).with_name("equivalent.toml")
# mutmut's exit codes that mean "killed"; -6 and -11 are a test process that crashed (SIGABRT,
# SIGSEGV: a mutant that hands NULL to libcosim or to an FMU): the suite fails, so it is detected
KILLED = {1, 3, 24, -24, 36, 37, 152, 255, -6, -11}


def equivalents(path: Path = EQUIVALENT_FILE) -> dict[str, str]:
    """mutant name -> the reason it is equivalent."""
    out: dict[str, str] = {}
    for group in tomllib.loads(path.read_text(encoding="utf-8")).get("group", []):
        for name in group["mutants"]:
            if name in out:
                raise ValueError(f"{path}: {name} is listed twice")
            out[name] = group["reason"]
    return out


def verdicts(mutants: Path) -> dict[str, dict[str, int | None]]:
    """source path -> {mutant name: mutmut's exit code, None when not run}."""
    out = {}
    for meta in sorted(mutants.rglob("*.py.meta")):
        source = meta.relative_to(mutants).as_posix()[: -len(".meta")]
        out[source] = json.loads(meta.read_text(encoding="utf-8"))["exit_code_by_key"]
    return out


def classify(code: int | None, name: str, equivalent: dict[str, str]) -> str:
    if code is None:
        return "not run"
    if code in KILLED:
        return "killed"
    return "equivalent" if name in equivalent else "not killed"


def table(by_source, equivalent) -> tuple[list[str], Counter, list[str]]:
    cols = ("killed", "equivalent", "not killed", "not run")
    lines = ["| module | mutants | killed | equivalent | not killed | not run | score |",
             "| --- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    total, stale = Counter(), []
    for source, codes in by_source.items():
        c = Counter(classify(code, name, equivalent) for name, code in codes.items())
        stale += [n for n, code in codes.items() if n in equivalent and code in KILLED]
        total.update(c)
        total["mutants"] += len(codes)
        lines.append(f"| `{source}` | {len(codes)} | " + " | ".join(str(c[k]) for k in cols)
                     + f" | {_score(c)} |")
    lines.append(f"| **total** | **{total['mutants']}** | "
                 + " | ".join(f"**{total[k]}**" for k in cols) + f" | **{_score(total)}** |")
    return lines, total, stale


def _score(c: Counter) -> str:
    decided = c["killed"] + c["not killed"]
    return f"{100.0 * c['killed'] / decided:.1f} %" if decided else "-"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mutants", type=Path, default=Path("mutants"), help="mutmut's folder")
    ap.add_argument("--survivors", action="store_true",
                    help="list the mutants not killed and not listed as equivalent")
    args = ap.parse_args(argv)
    if not args.mutants.is_dir():
        print(f"no {args.mutants}/ here: run `mutmut run` from the project root first", file=sys.stderr)
        return 2
    equivalent = equivalents()
    by_source = verdicts(args.mutants)
    lines, total, stale = table(by_source, equivalent)
    if args.survivors:
        for codes in by_source.values():
            for name, code in codes.items():
                if classify(code, name, equivalent) == "not killed":
                    print(name)
    else:
        print("\n".join(lines))
    unknown = set(equivalent) - {n for codes in by_source.values() for n in codes}
    for name in sorted(stale):
        print(f"listed as equivalent but killed: {name}", file=sys.stderr)
    for name in sorted(unknown):
        print(f"listed as equivalent but no such mutant: {name}", file=sys.stderr)
    return 1 if stale or unknown else 0


if __name__ == "__main__":
    raise SystemExit(main())
