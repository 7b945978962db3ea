"""tests/support/netkf_proc.py against shell processes (no DDS, so no namespace): output capture,
wait, the stop signal and its exit status, SIGKILL after the grace with the process group (and
only with it), kill_also, the `with` block, stop_process on a plain Popen.
Usage: python3 test_netkf_proc.py (ctest: netkf_proc_support)"""
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from netkf_proc import BackgroundProcess, stop_process  # noqa: E402

failures = []
out = tempfile.mkdtemp(prefix="netkf-proc-")
# Ignores SIGTERM, starts a child that outlives it unless killed, says the child's pid.
STUBBORN = "trap '' TERM; sleep 300 & echo child $!; wait"


def check(condition, message):
    print("  ok:" if condition else "  FAILED:", message, flush=True)
    if not condition:
        failures.append(message)


def alive(pid):
    """Runs (a zombie, killed and waiting for its parent to reap it, does not)."""
    try:
        with open("/proc/%d/stat" % pid) as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def gone(pid, seconds=10):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if not alive(pid):
            return True
        time.sleep(0.05)
    return False


def child_of(p):
    """The pid the STUBBORN shell printed, once it did."""
    end = time.monotonic() + 10
    while time.monotonic() < end:
        words = p.output().split()
        if len(words) >= 2:
            return int(words[1])
        time.sleep(0.05)
    raise RuntimeError("no child pid in %s" % p.log_path)


def capture():
    p = BackgroundProcess(["sh", "-c", "echo to-out; echo to-err >&2; exit 3"], log=os.path.join(out, "a.log"),
                          stdout=os.path.join(out, "a.out"))
    rc = p.stop(None, 30)  # no signal: it ends by itself
    p.close()
    check(rc == 3 and not p.killed, "no signal: the exit status of a process that ends by itself (%s)" % rc)
    check(p.stdout() == "to-out\n" and p.output() == "to-err\n",
          "stdout and stderr in their files, readable after close() (%r, %r)" % (p.stdout(), p.output()))
    p = BackgroundProcess(["sh", "-c", "echo one; echo two >&2"], log=os.path.join(out, "b.log"))
    rc = p.wait(30)
    p.close()
    check(rc == 0 and p.output() in ("one\ntwo\n", "two\none\n"), "both in `log` without `stdout` (%r)" % p.output())


def signals():
    p = BackgroundProcess(["sh", "-c", "trap 'exit 7' INT; echo ready; while :; do sleep 0.05; done"],
                          log=os.path.join(out, "c.log"))
    end = time.monotonic() + 10
    while "ready" not in p.output() and time.monotonic() < end:  # the trap is set
        time.sleep(0.05)
    check(p.wait(0.2) is None and p.running(), "wait(timeout) on a running process: None, and it still runs")
    rc = p.stop(signal.SIGINT, 30)
    check(rc == 7 and not p.killed, "stop(SIGINT): the handler's exit status (%s), no SIGKILL" % rc)
    check(p.stop() == 7, "stop() again: the same status, nothing sent")
    p.close()


def group_kill():
    p = BackgroundProcess(["sh", "-c", STUBBORN], log=os.path.join(out, "d.log"), new_session=True)
    child = child_of(p)
    rc = p.stop(signal.SIGTERM, 0.5)
    p.close()
    check(rc == -signal.SIGKILL and p.killed,
          "SIGTERM ignored: SIGKILL after the grace (%s, killed=%s)" % (rc, p.killed))
    check(gone(child), "new_session: the child it started is killed with it (pid %d)" % child)
    # Without its own session the child outlives it: kill_also names it.
    p = BackgroundProcess(["sh", "-c", STUBBORN], log=os.path.join(out, "e.log"))
    child = child_of(p)
    p.stop(signal.SIGTERM, 0.5)
    survived = alive(child)
    p.stop(signal.SIGKILL, 0, kill_also=lambda: [child])
    p.close()
    check(survived and gone(child), "no session: the child outlives the kill, kill_also() ends it (pid %d)" % child)


def context_and_popen():
    with BackgroundProcess(["sleep", "300"], stop_signal=signal.SIGINT, grace=10) as p:
        pass
    check(p.proc.returncode == -signal.SIGINT, "leaving `with`: stopped with its stop_signal (%s)"
          % p.proc.returncode)
    proc = subprocess.Popen(["sleep", "300"])
    rc, killed = stop_process(proc, signal.SIGTERM, 10)
    check(rc == -signal.SIGTERM and not killed, "stop_process on a Popen: (%s, %s)" % (rc, killed))


capture()
signals()
group_kill()
context_and_popen()
if failures:
    print("%d expectation(s) failed; output kept in %s" % (len(failures), out), flush=True)
    sys.exit(1)
print("all expectations met", flush=True)
shutil.rmtree(out, ignore_errors=True)
