#!/usr/bin/env python3
"""The totals at the end of scripts/test.sh: per build tree and suite (ctest label), the tests
run, passed and skipped, and those that passed only on their second try, read from ctest's
output. Labels come from the tree itself (ctest --show-only=json-v1).

Usage: ctest_totals.py TREE:FIRST_LOG[:SECOND_LOG]...   (a tree is build/TREE; SECOND_LOG: the
       re-run of the tests that failed in FIRST_LOG, when there was one)
"""
import json
import os
import re
import subprocess
import sys

# A test's name may hold spaces (a parameterised gtest's "NAME  # GetParam() = ..."): up to the dots.
RESULT = re.compile(r"^\s*\d+/\d+ Test\s+#\d+: (.+?) \.*\s*(?:\*\*\*)?([A-Za-z][A-Za-z ]*?)(?::.*?)?\s+[\d.]+ sec")


def results(path):
    """{test: "Passed" | "Skipped" | another status} of one ctest run's output."""
    found = {}
    if path and os.path.exists(path):
        with open(path, errors="replace") as f:
            for line in f:
                m = RESULT.match(line)
                if m:
                    found[m.group(1)] = m.group(2)
    return found


def labels(tree):
    r = subprocess.run(["ctest", "--test-dir", os.path.join("build", tree), "--show-only=json-v1"],
                       capture_output=True, text=True, check=True)
    names = {}
    for t in json.loads(r.stdout)["tests"]:
        label = "(no label)"
        for p in t.get("properties", []):
            if p["name"] == "LABELS":
                label = ",".join(p["value"])
        names[t["name"]] = label
    return names


def main():
    rows, all_run, all_passed, all_second = [], 0, 0, []
    for arg in sys.argv[1:]:
        tree, first, *rest = arg.split(":")
        second = results(rest[0]) if rest else {}
        runs = results(first)
        by_label = labels(tree)
        suites = {}
        for name, status in runs.items():
            s = suites.setdefault(by_label.get(name, "(no label)"), {"run": 0, "passed": 0, "skipped": 0, "second": []})
            s["run"] += 1
            if status == "Passed":
                s["passed"] += 1
            elif status == "Skipped":
                s["skipped"] += 1
            elif second.get(name) == "Passed":
                s["passed"] += 1
                s["second"].append(name)
        for label in sorted(suites):
            s = suites[label]
            note = []
            if s["skipped"]:
                note.append("%d skipped" % s["skipped"])
            if s["second"]:
                note.append("%d passed on a second try: %s" % (len(s["second"]), " ".join(s["second"])))
            rows.append("%-8s %-12s %4d run, %4d passed%s" % (tree, label, s["run"], s["passed"],
                                                              ("; " + "; ".join(note)) if note else ""))
            all_run += s["run"]
            all_passed += s["passed"]
            all_second += s["second"]
    rows.append("%-21s %4d run, %4d passed; %d e2e second tries" % ("all", all_run, all_passed, len(all_second)))
    print("\n".join(rows))


if __name__ == "__main__":
    main()
