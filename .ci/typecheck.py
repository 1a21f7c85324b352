"""Static types of fabpat/: mypy's errors may only shrink from the committed baseline (.ci/mypy-baseline.txt).

Run: ``python .ci/typecheck.py`` (CI does); ``--update`` rewrites the baseline after errors were fixed (it
refuses to add any). An error is keyed by file, code and message, not line number, so moving code does not
change the baseline; a new error (or one more of a kind in a file) fails with its mypy line.
"""

from __future__ import annotations

import collections
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BASELINE = ROOT / ".ci" / "mypy-baseline.txt"
ERROR = re.compile(r"^(?P<file>[^:]+):(?P<line>\d+): error: (?P<message>.*)$")


def run_mypy() -> tuple[collections.Counter[str], dict[str, str]]:
    out = subprocess.run([sys.executable, "-m", "mypy", "fabpat", "--ignore-missing-imports", "--no-error-summary",
                          "--hide-error-context", "--no-pretty"], cwd=ROOT, capture_output=True, text=True)
    if out.returncode not in (0, 1):
        sys.exit(f"mypy failed to run: {out.stderr.strip() or out.stdout.strip()}")
    keys: collections.Counter[str] = collections.Counter()
    example: dict[str, str] = {}
    for line in out.stdout.splitlines():
        m = ERROR.match(line)
        if m:
            key = f"{m['file']}: {m['message']}"
            keys[key] += 1
            example.setdefault(key, line)
    return keys, example


def main() -> int:
    now, example = run_mypy()
    base = collections.Counter(s for s in BASELINE.read_text().splitlines() if s) if BASELINE.exists() else None
    if "--update" in sys.argv:
        if base is not None and now - base:
            print("refusing to add errors to the baseline:", *sorted(now - base), sep="\n  ")
            return 1
        BASELINE.write_text("".join(f"{k}\n" for k in sorted(now.elements())))
        print(f"{BASELINE.name}: {sum(now.values())} errors")
        return 0
    if base is None:
        print(f"no baseline at {BASELINE}: run python .ci/typecheck.py --update")
        return 1
    new = now - base
    if new:
        print(f"mypy: {sum(new.values())} new type errors (fix them; the baseline only shrinks):")
        for k in sorted(new):
            print("  " + example[k])
        return 1
    gone = sum((base - now).values())
    print(f"mypy: {sum(now.values())} errors, none new" + (f"; {gone} fixed: run python .ci/typecheck.py --update"
                                                          if gone else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
