"""Compare the metrics of two run directories (or two trees of them), wall times aside.

    python -m harness.report.compare_metrics reports /tmp/regenerated

Every ``metrics.json`` under the first directory is compared with the file at the same relative
path under the second, value by value: numbers must be equal bit for bit, except wall-clock
measurements (``timing``, and the measured value of wall-clock claims such as ``real_time``),
``provenance`` and the effective ``config`` (its layout may change; compare ``config.toml`` files
for that). Exit status 0 when
all agree, 1 otherwise, with one line per difference.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from worlds.files import read_json

IGNORED = frozenset({"timing", "provenance", "config"})
WALL_CLOCK_CLAIMS = frozenset({"real_time"})  # claims whose measured value is a wall-clock speed


def differences(a, b, path: str = "", allow_new: bool = False) -> list[str]:
    """Where two parsed metrics documents differ (ignored keys skipped at any depth; with
    ``allow_new``, keys only in the second are not differences: metrics added since)."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        wall_clock_claim = a.get("key") in WALL_CLOCK_CLAIMS and "measured" in a
        for key in sorted(set(a) | set(b)):
            if key in IGNORED or (wall_clock_claim and key == "measured"):
                continue
            if key not in a and allow_new:
                continue
            if key not in a or key not in b:
                out.append(f"{path}/{key}: only in {'second' if key not in a else 'first'}")
                continue
            out += differences(a[key], b[key], f"{path}/{key}", allow_new)
        return out
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{path}: {len(a)} items vs {len(b)}"]
        return [d for i, (x, y) in enumerate(zip(a, b)) for d in differences(x, y, f"{path}[{i}]", allow_new)]
    if a != b and not (a != a and b != b):  # NaN equals NaN here
        return [f"{path}: {a!r} vs {b!r}"]
    return []


def compare_trees(first: Path, second: Path, allow_new: bool = False) -> list[str]:
    """Differences between every metrics.json under ``first`` and its counterpart under ``second``."""
    files = sorted(first.rglob("metrics.json")) if first.is_dir() else [first]
    if not files:
        return [f"{first}: no metrics.json found"]
    out = []
    for f in files:
        rel = f.relative_to(first) if first.is_dir() else Path(f.name)
        g = second / rel if second.is_dir() else second
        if not g.is_file():
            out.append(f"{rel}: missing in {second}")
            continue
        out += [f"{rel}: {d}" for d in differences(read_json(f), read_json(g), allow_new=allow_new)]
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("first", type=Path)
    parser.add_argument("second", type=Path)
    parser.add_argument(
        "--allow-new", action="store_true", help="keys only in the second are not differences (metrics added since)"
    )
    args = parser.parse_args(argv)
    diffs = compare_trees(args.first, args.second, args.allow_new)
    for line in diffs:
        print(line)
    print(
        "identical (wall times, provenance and config aside)" if not diffs else f"{len(diffs)} differences",
        file=sys.stderr,
    )
    return 1 if diffs else 0


if __name__ == "__main__":
    sys.exit(main())
