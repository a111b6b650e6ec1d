#!/usr/bin/env python3
"""Splits Catch2 test cases into N lists of about equal run time, for N processes side by side.

Usage: test_exe --list-test-names-only | scripts/split_cases.py N OUT_DIR COSTS...
Each COSTS is a ctest CTestCostData.txt (a case's average seconds); a case takes its time from the
first file that has it (Release runs the slow cases, ASan+UBSan the rest); unknown cases count as
the mean.
Writes OUT_DIR/cases-K.txt (K = 0..N-1), one name per line, escaped for Catch's -f option.
"""
import os
import re
import sys


def read_costs(path, costs):
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            for line in f:
                if line.startswith("---"):
                    break
                parts = line.rstrip("\n").rsplit(" ", 2)
                if len(parts) == 3 and re.fullmatch(r"[0-9.eE+-]+", parts[2]):
                    costs.setdefault(parts[0].removesuffix(" (slow)"), float(parts[2]))
    except OSError:
        pass


def main():
    n, out = int(sys.argv[1]), sys.argv[2]
    names = [line.strip() for line in sys.stdin if line.strip()]
    costs = {}
    for path in sys.argv[3:]:
        read_costs(path, costs)
    mean = sum(costs.values()) / len(costs) if costs else 1.0
    # Longest first, each to the list with the least time so far.
    lists = [[] for _ in range(n)]
    totals = [0.0] * n
    for name in sorted(names, key=lambda s: -costs.get(s, mean)):
        k = totals.index(min(totals))
        lists[k].append(name)
        totals[k] += costs.get(name, mean)
    os.makedirs(out, exist_ok=True)
    for k, cases in enumerate(lists):
        with open(os.path.join(out, f"cases-{k}.txt"), "w", encoding="utf-8") as f:
            # Catch reads commas as "or" and brackets as tags: escape them (as catch_discover_tests).
            f.writelines(re.sub(r"([\\,\[\]*])", r"\\\1", c) + "\n" for c in cases)


if __name__ == "__main__":
    main()
