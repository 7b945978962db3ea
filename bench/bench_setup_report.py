#!/usr/bin/env python3
"""The tables of BENCHMARKS.md's "Set-up and CI time" from the raw files of bench/bench_setup.sh.

Usage: bench_setup_report.py WORKDIR   (writes WORKDIR/report.md and prints it)
"""
import glob
import os
import re
import sys

work = sys.argv[1]
cores = os.cpu_count() or 1
HZ = os.sysconf("SC_CLK_TCK")
out = []


def emit(line=""):
    out.append(line)


def mmss(seconds):
    seconds = int(round(seconds))
    return "%d:%02d" % (seconds // 60, seconds % 60)


def load_samples():
    rows = []
    path = os.path.join(work, "load.txt")
    if os.path.exists(path):
        for line in open(path):
            t, load, idle = line.split()
            rows.append((float(t), float(load), float(idle)))
    return rows


SAMPLES = load_samples()


def machine(t0, t1):
    """Mean and max 1-min load average, and the mean number of idle cores, between t0 and t1."""
    inside = [s for s in SAMPLES if t0 <= s[0] <= t1]
    if not inside:
        return "–", "–", "–"
    loads = [s[1] for s in inside]
    idle = sum(s[2] for s in inside) / len(inside) * cores
    return "%.2f" % (sum(loads) / len(loads)), "%.2f" % max(loads), "%.2f" % idle


def time_v(name):
    """Wall and user+sys seconds from /usr/bin/time -v."""
    path = os.path.join(work, name + ".time")
    if not os.path.exists(path):
        return None
    text = open(path).read()
    found = [re.search(pattern, text) for pattern in (r"User time \(seconds\): ([\d.]+)",
                                                     r"System time \(seconds\): ([\d.]+)",
                                                     r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): ([\d:.]+)")]
    if not all(found):
        return None  # the session was stopped before /usr/bin/time wrote its summary
    user, sys_, wall = float(found[0].group(1)), float(found[1].group(1)), found[2].group(1)
    secs = 0.0
    for part in wall.split(":"):
        secs = secs * 60 + float(part)
    status = re.search(r"Exit status: (\d+)", text)
    return secs, user + sys_, int(status.group(1)) if status else None


def trace_phases(name):
    """The traced script's top-level commands: (command, start, end, cpu seconds)."""
    path = os.path.join(work, name + ".trace")
    if not os.path.exists(path):
        return []
    events = []
    start = end = None
    for line in open(path):
        m = re.match(r"^\+\+ (\d+\.\d+) (\d+) (\d+) (.*)$", line.rstrip("\n"))
        if m:
            events.append((float(m.group(1)), (int(m.group(2)) + int(m.group(3))) / HZ, m.group(4)))
            continue
        m = re.match(r"^(\d+\.\d+) (start|end)", line)
        if m:
            if m.group(2) == "start":
                start = float(m.group(1))
            else:
                end = float(m.group(1))
    phases = []
    for i, (t, cpu, cmd) in enumerate(events):
        t_next, cpu_next = (events[i + 1][0], events[i + 1][1]) if i + 1 < len(events) else (end, None)
        if t_next is None:
            continue
        phases.append((cmd, t, t_next, None if cpu_next is None else cpu_next - cpu))
    return phases


def session_table(names):
    emit("| session | wall | CPU (user+sys) | exit | load avg mean / max | idle cores (mean of %d) |" % cores)
    emit("|---|---|---|---|---|---|")
    for name in names:
        tv = time_v(name)
        if not tv:
            continue
        wall, cpu, rc = tv
        trace_path = os.path.join(work, name + ".trace")
        if os.path.exists(trace_path):
            t0 = float(open(trace_path).read().split("\n")[0].split()[0])
            mean, peak, idle = machine(t0, t0 + wall)
        else:  # timed without a trace (by hand): no load samples to match
            mean = peak = idle = "–"
        emit("| %s | %s (%.0f s) | %.0f s | %s | %s / %s | %s |" % (name, mmss(wall), wall, cpu, rc, mean, peak, idle))
    emit()


def phase_table(name, min_seconds=1.0):
    phases = [p for p in trace_phases(name) if p[2] - p[1] >= min_seconds]
    if not phases:
        return
    emit("`%s`, its steps of at least %.0f s:" % (name, min_seconds))
    emit()
    emit("| step | wall | CPU (user+sys) | load avg mean / max | idle cores |")
    emit("|---|---|---|---|---|")
    for cmd, t0, t1, cpu in phases:
        mean, peak, idle = machine(t0, t1)
        cmd = cmd if len(cmd) <= 90 else cmd[:87] + "..."
        emit("| `%s` | %s (%.0f s) | %s | %s / %s | %s |" % (cmd.replace("|", "\\|"), mmss(t1 - t0), t1 - t0,
                                                             "–" if cpu is None else "%.0f s" % cpu, mean, peak, idle))
    emit()


def ninja_edges(path):
    edges = {}
    for line in open(path):
        if line.startswith("#"):
            continue
        start, end, _mtime, output, _hash = line.rstrip("\n").split("\t")
        edges[output] = (int(end) - int(start)) / 1000.0
    return edges


def build_tables():
    logs = sorted(glob.glob(os.path.join(work, "ninja-*-cold.log")))
    if not logs:
        return
    emit("Build trees, cold (`.ninja_log`: every edge once; the sum is close to the compile CPU time):")
    emit()
    emit("| tree | edges | compile units (.o) | sum of edge times | of which the ten slowest |")
    emit("|---|---|---|---|---|")
    slowest = {}
    for path in logs:
        tree = re.match(r".*ninja-(.*)-cold\.log", path).group(1)
        edges = ninja_edges(path)
        objs = {k: v for k, v in edges.items() if k.endswith(".o")}
        top = sorted(objs.items(), key=lambda kv: -kv[1])[:10]
        slowest[tree] = top
        emit("| %s | %d | %d | %.0f s | %.0f s |" % (tree, len(edges), len(objs), sum(edges.values()),
                                                    sum(v for _, v in top)))
    emit()
    for tree, top in slowest.items():
        emit("Ten slowest translation units of `%s`: %s" % (tree, ", ".join(
            "%s %.0f s" % (re.sub(r"^.*CMakeFiles/", "", k).replace(".dir/", ":").replace(".cpp.o", "").replace(
                ".cxx.o", ".cxx"), v) for k, v in top)))
        emit()


def suite_of(test):
    for prefix in ("unit", "validation", "integration", "e2e", "fuzz", "deploy"):
        if test.startswith(prefix):
            return prefix
    if test.startswith("python"):
        return "python"
    if "." in test:  # gtest names of a test program without a suite prefix
        return "gtest"
    return "other"


def ctest_costs(path):
    costs = {}
    for line in open(path):
        if line.startswith("---"):
            break
        parts = line.split()
        if len(parts) == 3:
            costs[parts[0]] = float(parts[2])
    return costs


def test_tables():
    files = sorted(glob.glob(os.path.join(work, "ctest-cost-*-cold.txt")))
    if not files:
        return
    emit("Tests, cold run (ctest's own per-test times, `CTestCostData.txt`):")
    emit()
    emit("| tree | suite | tests | sum of test times | longest |")
    emit("|---|---|---|---|---|")
    tops = {}
    for path in files:
        tree = re.match(r".*ctest-cost-(.*)-cold\.txt", path).group(1)
        costs = ctest_costs(path)
        by_suite = {}
        for name, cost in costs.items():
            by_suite.setdefault(suite_of(name), []).append((cost, name))
        for suite, rows in sorted(by_suite.items()):
            rows.sort(reverse=True)
            emit("| %s | %s | %d | %.0f s | %s %.0f s |" % (tree, suite, len(rows), sum(c for c, _ in rows), rows[0][1],
                                                          rows[0][0]))
        tops[tree] = sorted(((c, n) for n, c in costs.items()), reverse=True)[:10]
    emit()
    for tree, top in tops.items():
        emit("Ten slowest tests of `%s`: %s" % (tree, ", ".join("%s %.0f s" % (n, c) for c, n in top)))
        emit()


def ccache_line(name, label):
    path = os.path.join(work, name)
    if not os.path.exists(path):
        return
    text = open(path).read()
    hits = re.search(r"Hits:\s+(\d+) /\s+(\d+)", text)
    misses = re.search(r"Misses:\s+(\d+)", text)
    if hits:
        emit("%s: ccache hits %s of %s cacheable calls, misses %s." % (label, hits.group(1), hits.group(2),
                                                                     misses.group(1) if misses else "?"))
        emit()


emit("Sessions (each README command as its own process; the demo's live run is `--duration` long):")
emit()
session_table(["cold-deps", "cold-demo", "cold-test", "warm-demo", "warm-test", "clone2-build-default"])
for name in ("cold-demo", "cold-test", "warm-demo", "warm-test"):
    phase_table(name)
build_tables()
test_tables()
ccache_line("ccache-after-cold.txt", "Cold session (demo and tests) on an empty cache")
ccache_line("ccache-clone2.txt", "A second clone at another path, same cache, `scripts/build.sh default`")
text = "\n".join(out) + "\n"
open(os.path.join(work, "report.md"), "w").write(text)
sys.stdout.write(text)
