"""Fixtures of the reader's tests.

`live`: the files written by the real launch (live_runs.py, run once per session inside a
private network namespace through scripts/in-netns.sh, on DDS domain $NETKF_DOMAIN, 94 by
default). The netkf binary is $NETKF_BIN_DIR/cli/netkf (ctest sets it: there a missing binary
fails), else build/default/cli/netkf (when that is not built either, the live tests skip).
"""
import json
import os
import subprocess
import sys

import pytest

TESTS = os.path.dirname(os.path.abspath(__file__))
PYTHON_DIR = os.path.dirname(TESTS)
REPO = os.path.dirname(PYTHON_DIR)
DATA = os.path.join(TESTS, "data")
sys.path.insert(0, PYTHON_DIR)


@pytest.fixture(scope="session")
def data_dir():
    return DATA


def netkf_binary():
    """$NETKF_BIN_DIR/cli/netkf (a missing one fails), else build/default/cli/netkf (a missing
    one skips the test)."""
    bin_dir = os.environ.get("NETKF_BIN_DIR")
    netkf = os.path.join(bin_dir or os.path.join(REPO, "build", "default"), "cli", "netkf")
    if not os.path.exists(netkf):
        if bin_dir:
            pytest.fail("NETKF_BIN_DIR is set but %s does not exist" % netkf)
        pytest.skip("netkf is not built (build/default/cli/netkf): this test needs it")
    return netkf


@pytest.fixture(scope="session")
def live(tmp_path_factory):
    netkf = netkf_binary()
    out = str(tmp_path_factory.mktemp("live"))
    domain = os.environ.get("NETKF_DOMAIN", "94")
    cmd = [os.path.join(REPO, "scripts", "in-netns.sh"), sys.executable, os.path.join(TESTS, "live_runs.py"),
           netkf, out, domain]
    print("$", " ".join(cmd), flush=True)
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    if r.returncode != 0:
        pytest.fail("live_runs.py failed (rc=%d): %s %s" % (r.returncode, r.stdout[-2000:], r.stderr[-2000:]))
    with open(os.path.join(out, "runs.json")) as f:
        runs = json.load(f)
    for name, run in runs.items():
        if run["launch_rc"] != 0 or run["record_rc"] != 0:
            pytest.fail("run %s: launch rc=%s, record rc=%s\n%s" % (name, run["launch_rc"], run["record_rc"],
                                                                    "\n".join(run["logs"].values())))
    return runs
