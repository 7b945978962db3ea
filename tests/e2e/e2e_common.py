"""Shared fixture of the end-to-end tests: run `netkf launch` (real processes, real
Fast DDS) inside the test's network namespace, make sure every process it started is
ended, and read the CSV recordings.

Each test runs as `scripts/in-netns.sh python3 test_x.py` (ctest adds the wrapper), on its
own DDS domain ($NETKF_DOMAIN, set per test by CMake) so tests can run in parallel.
Environment (set by tests/e2e/CMakeLists.txt):
  NETKF_BIN_DIR   build tree root (netkf and node executables are found from it)
  NETKF_REPLAY    path of the netkf_replay helper
  NETKF_DOMAIN    DDS domain of this test
"""
import csv
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
# The shared test support (tests/support: starting and stopping background processes).
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "support"))
import netkf_proc  # noqa: E402
from netkf_proc import BackgroundProcess  # noqa: E402

DATA = os.path.join(HERE, "data")
BIN = os.environ.get("NETKF_BIN_DIR", "")
NETKF = os.path.join(BIN, "cli", "netkf")

_failures = []
_workdirs = []


def check(condition, message):
    """Record a failed expectation (the test continues to report all of them); returns whether it held."""
    if condition:
        print("  ok:", message, flush=True)
    else:
        print("  FAILED:", message, flush=True)
        _failures.append(message)
    return bool(condition)


def finish():
    if _failures:
        print("%d expectation(s) failed; recordings kept in %s" % (len(_failures), ", ".join(_workdirs)), flush=True)
        sys.exit(1)
    print("all expectations met", flush=True)
    for d in _workdirs:  # keep the recordings of a failed test for inspection
        shutil.rmtree(d, ignore_errors=True)
    sys.exit(0)


def require_netns():
    if os.environ.get("NETKF_IN_NETNS") != "1":
        print("e2e tests must run inside scripts/in-netns.sh (private network namespace)")
        sys.exit(2)


def workdir(name):
    d = tempfile.mkdtemp(prefix="netkf-e2e-%s-" % name)
    _workdirs.append(d)
    return d


class Launch:
    """`netkf launch` in the background; ended (and its children with it) on exit."""

    def __init__(self, scenario, duration, outdir, record=True, samples=False, extra=(), own_stdout=False, prefix=(),
                 name="launch"):
        """own_stdout: keep launch's stdout (e.g. the checks' table) apart from its log, in
        self.stdout_path, instead of merging it into the log. prefix: run it through this command
        (e.g. in another test host's namespace; it must exec netkf, so the pid is launch's own)."""
        self.record = os.path.join(outdir, "periods.csv") if record else None
        self.samples = os.path.join(outdir, "samples.csv") if samples else None
        self.pid_file = os.path.join(outdir, "%s-pids.txt" % name)
        self.log_path = os.path.join(outdir, "%s.log" % name)
        cmd = list(prefix) + [NETKF, "launch"]
        if scenario:
            cmd.append(scenario)
        if duration:
            cmd += ["--duration", str(duration)]
        cmd += ["--pid-file", self.pid_file, "--status-interval", "1"]
        if self.record:
            cmd += ["--record", self.record]
        if self.samples:
            cmd += ["--record-samples", self.samples]
        cmd += list(extra)
        self.stdout_path = os.path.join(outdir, "%s-stdout.txt" % name) if own_stdout else None
        # Own session: the fixture can signal launch and everything it spawned.
        self.process = BackgroundProcess(cmd, log=self.log_path, stdout=self.stdout_path, new_session=True)
        self.proc = self.process.proc
        self.started = time.monotonic()

    def wait(self, timeout):
        rc = self.process.wait(timeout)
        if rc is None:
            print("launch did not end in time; stopping it", flush=True)
            self.stop()
        return rc

    def stop(self):
        """SIGTERM, then SIGKILL after 10 s to whatever is left in the session (launch and its
        children, also those its pid file names)."""
        self.process.stop(signal.SIGTERM, 10, kill_also=lambda: self.child_pids().values())

    def child_pids(self):
        pids = {}
        try:
            with open(self.pid_file) as f:
                for line in f:
                    name, pid = line.rsplit(" ", 1)
                    pids[name] = int(pid)
        except (OSError, ValueError):
            pass
        return pids

    def output(self):
        return self.process.output()  # also readable after the run's `with` block

    def stdout(self):
        """What launch wrote to its stdout (own_stdout=True)."""
        return self.process.stdout()

    def __enter__(self):
        return self

    def interrupt(self, timeout=30):
        """Ctrl-C: launch stops its children and exits; returns its exit status."""
        self.process.send(signal.SIGINT)
        return self.wait(timeout)

    def __exit__(self, *exc):
        self.stop()
        text = self.output()
        if self.stdout_path:
            print("---- launch stdout ----")
            print(self.stdout(), end="", flush=True)
        self.process.close()
        print("---- %s output (tail) ----" % os.path.basename(self.log_path))
        print("\n".join(text.splitlines()[-40:]), flush=True)
        return False


class LoggedProcesses:
    """Processes a test starts in the background (Cyclone talkers and listeners, `netkf relay`),
    each with its stdout in OUTDIR/NAME.out and its stderr in OUTDIR/NAME.log."""

    def __init__(self, outdir, env):
        self.outdir, self.env = outdir, env

    def start(self, name, cmd, environment=None):
        """The process's subprocess.Popen (end it with stop_process)."""
        return BackgroundProcess(cmd, log=os.path.join(self.outdir, name + ".log"),
                                 stdout=os.path.join(self.outdir, name + ".out"),
                                 env=self.env if environment is None else environment).proc

    def text(self, name, ext):
        with open(os.path.join(self.outdir, name + ext)) as f:
            return f.read()


def stop_process(proc, timeout=20):
    """SIGINT, then SIGKILL after `timeout` s; the exit status."""
    return netkf_proc.stop_process(proc, signal.SIGINT, timeout)[0]


def cyclone_programs(*variables):
    """The Cyclone DDS test programs the environment names (e.g. NETKF_CYCLONE_CHATTER), built by
    tests/interop when Cyclone DDS is installed; when one is missing the test ends: skipped (77,
    ctest's SKIP_RETURN_CODE), or failed in CI and with NETKF_REQUIRE_INTEROP."""
    paths = [os.environ.get(v, "") for v in variables]
    if all(p and os.access(p, os.X_OK) for p in paths):
        return paths[0] if len(paths) == 1 else paths
    required = os.environ.get("NETKF_REQUIRE_INTEROP") in ("1", "ON", "TRUE", "true") or os.environ.get("CI") == "true"
    print("%s not built (Cyclone DDS missing: install cyclonedds-dev cyclonedds-tools, scripts/deps.sh)"
          % " / ".join(v.lower() for v in variables), flush=True)
    sys.exit(1 if required else 77)


class CycloneReader:
    """tests/interop/netkf_cyclone_reader (or its ROS 2 build) in the background: JSON lines on
    stdout, its log on stderr; CYCLONEDDS_URI set to `config_uri`, or unset (Cyclone's defaults)."""

    def __init__(self, exe, domain, outdir, name, config_uri):
        self.out_path = os.path.join(outdir, name + ".jsonl")
        self.err_path = os.path.join(outdir, name + ".log")
        env = dict(os.environ)
        env.pop("CYCLONEDDS_URI", None)
        if config_uri:
            env["CYCLONEDDS_URI"] = config_uri
        cmd = [exe, "--domain", str(domain), "--duration", "120"]
        print("$", ("CYCLONEDDS_URI=%s " % config_uri if config_uri else ""), " ".join(cmd), flush=True)
        self.process = BackgroundProcess(cmd, log=self.err_path, stdout=self.out_path, env=env,
                                         stop_signal=signal.SIGINT, grace=15, echo=False)
        self.proc = self.process.proc

    def log(self):
        with open(self.err_path) as f:
            return f.read()

    def stop(self):
        """SIGINT, then SIGKILL after 15 s; the exit status."""
        rc = self.process.stop()
        self.process.close()
        return rc

    def lines(self):
        """Each line as a dict; doubles kept as the text the reader printed (%.17g; a whole
        number such as "0" parses as an int, whose str() is that text again)."""
        with open(self.out_path) as f:
            return [json.loads(l, parse_float=str) for l in f if l.strip()]


def wait_for(predicate, seconds):
    """Poll `predicate` until it holds (True) or `seconds` pass (False)."""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(0.2)
    return False


def last_period(path):
    """The newest period k in a --record CSV so far (-1 when none): for waiting on progress
    rather than on the clock, which a loaded machine makes unreliable."""
    try:
        with open(path) as f:
            lines = f.read().splitlines()
        return int(lines[-1].split(",", 1)[0]) if len(lines) > 1 else -1
    except (OSError, ValueError):
        return -1


NODE = shutil.which("node") or "/usr/bin/node"
REPO = os.path.dirname(os.path.dirname(HERE))


def node(script, *args, timeout=120):
    """Run one of the Node.js test clients next to this file (run from the repository, where
    node_modules is); they print one JSON object."""
    cmd = [NODE, os.path.join(HERE, script)] + [str(a) for a in args]
    print("$", " ".join(cmd), flush=True)
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd=REPO)
    if r.stderr:
        print(r.stderr[-3000:], flush=True)
    try:
        return json.loads(r.stdout)
    except ValueError:
        print("node output:", r.stdout[-3000:], flush=True)
        check(False, "%s printed one JSON object (rc=%d)" % (script, r.returncode))
        return {}


def netkf(*args, timeout=30):
    cmd = [NETKF] + [str(a) for a in args]
    print("$", " ".join(cmd), flush=True)
    # errors="replace": a message that echoes a binary file's bytes is a failed expectation, not a crash.
    r = subprocess.run(cmd, capture_output=True, text=True, errors="replace", timeout=timeout)
    print(r.stdout, r.stderr, sep="", end="", flush=True)
    return r


def read_periods(path, n, m=None, truth_only=False):
    """Rows of a --record CSV as dicts with numeric fields; checks the exact header. m: the plant's
    input dimension of a closed loop (its rows end with the applied input u, in "u"); None: as
    many u columns as the header ends with (u0, u1, ... in order). Rows of
    periods without an estimate (state `none`: the estimator was stopped, or the run ended first)
    are left out unless truth_only, which keeps them with "xhat" and "trace_P" None. A scenario
    with an actuation link (plant.control.link) ends the header with "nu": whether u_{k-1} reached
    the plant in time (1/0), in "nu" (None without the column)."""
    with open(path) as f:
        reader = csv.reader(f)
        header = next(reader)
        if m is None:
            m = 0
            while "u%d" % m in header:
                m += 1
        with_nu = bool(header) and header[-1] == "nu"
        expected = ["k", "t"] + ["x%d" % i for i in range(n)] + ["xhat%d" % i for i in range(n)] + \
            ["trace_P", "fused", "late", "state", "late_samples"] + ["u%d" % i for i in range(m)] + \
            (["nu"] if with_nu else [])
        check(header == expected, "record header is exactly %s" % ",".join(expected))
        rows = []
        for c in reader:
            nu = int(c[-1]) if with_nu else None
            if with_nu:
                c = c[:-1]
            u = [float(v) for v in c[len(c) - m:]] if m else []
            if c[5 + 2 * n] == "none":
                if truth_only:
                    rows.append({"k": int(c[0]), "t": float(c[1]), "x": [float(v) for v in c[2:2 + n]],
                                 "xhat": None, "trace_P": None, "fused": [], "late": 0, "state": "none",
                                 "late_samples": [], "u": u, "nu": nu, "raw": c})
                continue
            rows.append({
                "k": int(c[0]), "t": float(c[1]),
                "x": [float(v) for v in c[2:2 + n]],
                "xhat": [float(v) for v in c[2 + n:2 + 2 * n]],
                "trace_P": float(c[2 + 2 * n]),
                "fused": [int(v) for v in c[3 + 2 * n].split(";") if v],
                "late": int(c[4 + 2 * n]),
                "state": c[5 + 2 * n],
                # (k, sensor id) of each sample counted in `late`: each for an earlier period
                "late_samples": [tuple(int(v) for v in s.split(":")) for s in c[6 + 2 * n].split(";") if s],
                "u": u,
                "nu": nu,
                "raw": c,
            })
    return rows


def read_samples(path):
    with open(path) as f:
        reader = csv.reader(f)
        next(reader)
        return [{"k": int(c[0]), "sensor_id": int(c[1]), "stamp": float(c[2]), "fused": c[3] == "1",
                 "y": [float(v) for v in c[4:] if v != ""]} for c in reader]


def inputs_missing(rows):
    """The periods k >= 1 of a closed loop's recording (read_periods(..., truth_only=True)) whose
    applied input (u_{k-1}, in row k) was zero because none arrived in time: u == 0 while the
    recorded estimate of k - 1 is not zero (u = -L x̂ is a true zero when x̂ = 0, e.g. a dead-beat
    gain after a period that fused nothing), or there is no estimate of k - 1."""
    by_k = {r["k"]: r for r in rows}
    missing = []
    for r in rows:
        prev = by_k.get(r["k"] - 1)
        if r["k"] < 1 or not r["u"] or any(v != 0.0 for v in r["u"]):
            continue
        if prev is None or prev["xhat"] is None or any(v != 0.0 for v in prev["xhat"]):
            missing.append(r["k"])
    return missing


def all_finite(rows):
    for r in rows:
        for cell in r["raw"]:
            if cell.lower() in ("nan", "-nan", "inf", "-inf"):
                return False
        if r["xhat"] is None:
            if not all(math.isfinite(v) for v in r["x"] + r["u"]):
                return False
            continue
        if not all(math.isfinite(v) for v in r["x"] + r["xhat"] + [r["trace_P"]] + r["u"]):
            return False
    return True


def contiguous(rows):
    ks = [r["k"] for r in rows]
    return ks == list(range(ks[0], ks[0] + len(ks))) if ks else False


def netkf_processes(domain):
    """pids of netkf node processes (from this build) still running on `domain`: a run that
    ended must leave none behind."""
    found = []
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            with open("/proc/%s/cmdline" % pid, "rb") as f:
                argv = f.read().split(b"\0")
        except OSError:
            continue
        if not argv or not argv[0].startswith(BIN.encode()):
            continue
        for i, a in enumerate(argv[:-1]):
            if a == b"--domain" and argv[i + 1] == str(domain).encode():
                found.append(int(pid))
    return found


def sensor_process_name(ids):
    """The launch's name of a sensor process (launch_plan.hpp): runs of three or more ids as
    ranges, sensor_node[1-3,5,7,8]."""
    parts, i = [], 0
    while i < len(ids):
        j = i
        while j + 1 < len(ids) and ids[j + 1] == ids[j] + 1:
            j += 1
        if j >= i + 2:
            parts.append("%d-%d" % (ids[i], ids[j]))
            i = j + 1
        else:
            parts.append(str(ids[i]))
            i += 1
    return "sensor_node[%s]" % ",".join(parts)


def node_pids(domain):
    """The netkf node processes of this build running on `domain` now (restarted ones included),
    found in /proc, as {name: pid}: plant_node, channel_emulator, estimator_node (each estimator
    as "estimator_node@STRENGTH", its --ownership-strength), sensor_node[1,2] (sensor_process_name). Warm spares (argv
    --spare, even once activated) are left out: Launch.child_pids() names the running processes
    of a launch, spares included."""
    found = {}
    for pid in netkf_processes(domain):
        try:
            with open("/proc/%d/cmdline" % pid, "rb") as f:
                argv = [a.decode() for a in f.read().split(b"\0") if a]
        except OSError:
            continue
        if not argv:  # it ended meanwhile (a zombie has no command line)
            continue
        name = os.path.basename(argv[0])
        if "--spare" in argv:
            continue
        if name == "sensor_node":
            name = sensor_process_name([int(argv[i + 1]) for i, a in enumerate(argv[:-1]) if a == "--sensor-id"])
        elif name == "estimator_node" and "--ownership-strength" in argv:
            name += "@" + argv[argv.index("--ownership-strength") + 1]
        found[name] = pid
    return found


def primary_estimator(domain):
    """(pid, strength) of the strongest estimator running on `domain`: the one whose inputs the
    plant applies (exclusive ownership), or None."""
    best = None
    for name, pid in node_pids(domain).items():
        if name.startswith("estimator_node@"):
            strength = int(name.split("@", 1)[1])
            if best is None or strength > best[1]:
                best = (pid, strength)
    return best


def launch_files_dirs(launch_pid):
    """The private directories `netkf launch` with this pid keeps its files in (cli/launch/launch_files.hpp)."""
    runtime = os.environ.get("XDG_RUNTIME_DIR")
    base = os.path.join(runtime, "netkf") if runtime and os.path.isdir(runtime) else \
        os.path.join(tempfile.gettempdir(), "netkf-%d" % os.getuid())
    try:
        return [os.path.join(base, d) for d in os.listdir(base) if d.startswith("launch-%d-" % launch_pid)]
    except OSError:
        return []


def _unlocked(names):
    """Those files of /dev/shm that no live process holds a lock on (the kernel drops the locks
    of a process that dies, so such a file was left by a killed process)."""
    import fcntl
    free = []
    for name in names:
        try:
            with open(os.path.join("/dev/shm", name), "ab") as f:
                try:
                    fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
                    fcntl.flock(f, fcntl.LOCK_UN)
                    free.append(name)
                except OSError:
                    pass  # held by a live process
        except OSError:
            pass
    return free


def _shm_names():
    try:
        return os.listdir("/dev/shm")
    except OSError:
        return []


def stale_participant_markers(domain):
    """netkf's participant-id markers of `domain` (/dev/shm/netkf_participant_d<domain>_id<N>,
    dds/include/netkf/dds/participant_slot.hpp) that no live process holds: left by a killed
    process until a launch removes them."""
    prefix = "netkf_participant_d%d_id" % domain
    return _unlocked([n for n in _shm_names() if n.startswith(prefix)])


def zombie_shm_segments():
    """Fast DDS shared-memory segments no live process holds (what `fastdds shm clean` would
    remove), found the way the tool finds them: a segment's lock file that nobody has locked."""
    import re
    segment_lock = re.compile(r"^fastrtps_[0-9a-z]{16}_el$")
    return _unlocked([n for n in _shm_names() if segment_lock.match(n)])


def numpy_filter_worst(rows, samples):
    """An independent NumPy Kalman filter for data/exact.yaml's model (stacked form, Sinopoli
    eqs. 14-16 with the received rows only) over the samples the live run fused: the largest
    difference from the recorded x̂ and Tr P. Periods fused with nothing are predictions."""
    import numpy as np
    A = np.array([[0.9, 0.2], [-0.1, 0.8]])
    Q = np.diag([0.2, 0.1])
    C = {1: np.array([[1.0, 0.0]]), 2: np.array([[0.5, 1.0]])}
    R = {1: 0.5, 2: 0.8}
    x = np.array([1.0, -1.0])
    P = np.diag([2.0, 2.0])
    by_k = {}
    for s in samples:
        if s["fused"]:
            by_k.setdefault(s["k"], []).append(s)
    recorded = {r["k"]: r for r in rows}
    worst = 0.0
    for k in range(0, rows[-1]["k"] + 1 if rows else 0):
        got = sorted(by_k.get(k, []), key=lambda s: s["sensor_id"])
        if got:
            Cs = np.vstack([C[s["sensor_id"]] for s in got])
            S = Cs @ P @ Cs.T + np.diag([R[s["sensor_id"]] for s in got])
            K = P @ Cs.T @ np.linalg.inv(S)
            x = x + K @ (np.array([s["y"][0] for s in got]) - Cs @ x)
            P = P - K @ Cs @ P
        if k in recorded:
            worst = max(worst, float(np.max(np.abs(x - np.array(recorded[k]["xhat"])))),
                        abs(np.trace(P) - recorded[k]["trace_P"]))
            if sorted(recorded[k]["fused"]) != [s["sensor_id"] for s in got]:
                worst = float("inf")  # the recorded fused set disagrees with the samples' flags
        x = A @ x
        P = A @ P @ A.T + Q
    return worst
