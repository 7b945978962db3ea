"""Start, wait for and stop a background process in the Python tests (docs/testing.md, "Shared
test support"): the e2e fixture (tests/e2e/e2e_common.py), the e2e tests and the Python reader's
live runs (python/tests/live_runs.py) use it, so every process a test starts is signalled, killed
when it does not end, and reaped the same way. Python 3.11 standard library only.

    with BackgroundProcess(argv, log=path, new_session=True) as p:   # stdout and stderr in `path`
        ...
        rc = p.stop(signal.SIGINT, grace=20)   # SIGINT, SIGKILL after 20 s, reaped: the exit status
    text = p.output()

A test's process that never ends by itself is stopped on leaving the `with` block (with the
signal and grace given to the constructor).
"""
import os
import signal
import subprocess


_DEFAULT = object()  # stop(): the constructor's stop_signal / grace


def stop_process(proc, sig=signal.SIGTERM, grace=10.0, group=False, kill_also=None):
    """Send `sig` to `proc` (a subprocess.Popen) while it runs (None: send nothing, let it end by
    itself), wait `grace` s, then SIGKILL what is left: the process, its process group when
    `group` (it was started in its own session: whatever it spawned), and the pids `kill_also()`
    returns. Always reaps; returns the exit status (negative: the signal that ended it) and
    whether SIGKILL was needed."""
    if sig is not None and proc.poll() is None:
        proc.send_signal(sig)
    try:
        proc.wait(timeout=grace)
    except subprocess.TimeoutExpired:
        pass
    killed = proc.poll() is None
    pids = ([proc.pid] if killed else []) + list(kill_also() if kill_also else [])
    for pid in pids:
        _kill(os.kill, pid)
    if group:  # the session's other members (children that outlived it) share its pid as group id
        _kill(os.killpg, proc.pid)
    return proc.wait(), killed


def _kill(how, pid):
    try:
        how(pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass


class BackgroundProcess:
    """`argv` in the background with its output in files: stdout and stderr both in `log`, or
    stdout in `stdout` and stderr in `log` (each None: discarded). `new_session`: its own session
    and process group, so that stop() also kills whatever it spawned. `stop_signal` and `grace`:
    how leaving the `with` block stops it. `echo`: print the command line first."""

    def __init__(self, argv, log=None, stdout=None, env=None, cwd=None, new_session=False,
                 stop_signal=signal.SIGTERM, grace=10.0, echo=True):
        self.argv = list(argv)
        self.log_path, self.stdout_path = log, stdout
        self.new_session = new_session
        self.stop_signal, self.grace = stop_signal, grace
        self.killed = False  # stop() had to SIGKILL it
        if echo:
            print("$", " ".join(self.argv), flush=True)
        self._log = open(log, "w") if log else None
        self._stdout = open(stdout, "w") if stdout else None
        out = self._stdout or self._log or subprocess.DEVNULL
        err = (self._log or subprocess.DEVNULL) if stdout else subprocess.STDOUT
        if out is subprocess.DEVNULL and err is subprocess.STDOUT:
            err = subprocess.DEVNULL
        self.proc = subprocess.Popen(self.argv, stdout=out, stderr=err, env=env, cwd=cwd,
                                     start_new_session=new_session)
        self.pid = self.proc.pid

    def running(self):
        return self.proc.poll() is None

    def send(self, sig):
        """Send `sig` while it runs (a reaped pid may belong to another process by now)."""
        if self.proc.poll() is None:
            self.proc.send_signal(sig)

    def wait(self, timeout):
        """Its exit status once it ends, or None when it still runs after `timeout` s (it is left
        running: stop() it)."""
        try:
            return self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            return None

    def stop(self, sig=_DEFAULT, grace=_DEFAULT, kill_also=None):
        """stop_process() with this process's group: `sig` (default: the constructor's stop_signal;
        None: none, it ends by itself), SIGKILL after `grace` s, reaped; the exit status. Also when
        it has already ended: then only what it left in its session is killed."""
        rc, killed = stop_process(self.proc, self.stop_signal if sig is _DEFAULT else sig,
                                  self.grace if grace is _DEFAULT else grace, self.new_session, kill_also)
        self.killed = self.killed or killed
        return rc

    def kill(self, kill_also=None):
        """SIGKILL now (and its group, and kill_also()); reaped; the exit status."""
        return self.stop(signal.SIGKILL, 0, kill_also)

    def output(self):
        """What it wrote to `log` so far (also after close())."""
        return self._read(self._log, self.log_path)

    def stdout(self):
        """What it wrote to `stdout` so far (also after close())."""
        return self._read(self._stdout, self.stdout_path)

    @staticmethod
    def _read(f, path):
        if f is not None and not f.closed:
            f.flush()
        with open(path) as r:
            return r.read()

    def close(self):
        """Our handles of its output files (the process keeps its own)."""
        for f in (self._log, self._stdout):
            if f is not None:
                f.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.stop()
        self.close()
        return False
