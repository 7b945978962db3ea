#!/usr/bin/python3
"""Independent NumPy cross-check of `netkf analyze --json` (label: validation).

For each scenario in tests/data/theory with Bernoulli links, recompute with plain NumPy:
  * Tr S-bar from the Lyapunov equation S = q A S A' + Q (vectorised Kronecker solve),
  * Tr V-bar by iterating the expected Riccati map (Liu-Goldsmith eq. 12 over all 2^d
    arrival patterns; Sinopoli eq. 17 for d = 1) from V = 0 until it stops changing,
  * the exact critical rate of a shared-rate scenario from You et al./multi-sensor paper for
    one-dimensional eigen-blocks: alpha_i^2 * (1 - lambda)^(#sensors seeing block i) < 1,
and compare with the implementation. Nothing here reads netkf's output as an expectation.
Usage: numpy_bounds.py NETKF_BINARY DATA_DIR
"""
import itertools
import json
import subprocess
import sys
from pathlib import Path

import numpy as np


def load(path):
    # A tiny reader for the flat scenario files of this directory (flow-style YAML lists);
    # the test files are written so that json can parse each value after light cleanup.
    import re
    text = Path(path).read_text()
    text = re.sub(r"#.*", "", text)
    def grab(key, block):
        m = re.search(key + r":\s*(\[\[.*?\]\])", block, re.S)
        return np.array(json.loads(m.group(1)), dtype=float)
    plant = text.split("sensors:")[0]
    A, Q = grab("A", plant), grab("Q", plant)
    sensors = []
    for chunk in text.split("sensors:")[1].split("- id:")[1:]:
        C, R = grab("C", chunk), grab("R", chunk)
        link = re.search(r"link:\s*\{(.*?)\}", chunk).group(1)
        fields = dict((k.strip(), v.strip()) for k, v in (f.split(":") for f in link.split(",")))
        sensors.append((C, R, fields))
    return A, Q, sensors


def expected_map(A, Q, sensors, rates, X):
    out = A @ X @ A.T + Q
    d = len(sensors)
    for mask in itertools.product([0, 1], repeat=d):
        prob = np.prod([r if m else 1 - r for m, r in zip(mask, rates)])
        if prob == 0 or not any(mask):
            continue
        C = np.vstack([sensors[i][0] for i in range(d) if mask[i]])
        R = np.zeros((C.shape[0], C.shape[0]))
        row = 0
        for i in range(d):
            if mask[i]:
                m = sensors[i][1].shape[0]
                R[row:row + m, row:row + m] = sensors[i][1]
                row += m
        S = C @ X @ C.T + R
        out = out - prob * A @ X @ C.T @ np.linalg.solve(S, C @ X @ A.T)
    return 0.5 * (out + out.T)


def upper_trace(A, Q, sensors, rates, iters=200000):
    X = np.zeros_like(A)
    for _ in range(iters):
        Y = expected_map(A, Q, sensors, rates, X)
        if not np.all(np.isfinite(Y)) or np.trace(Y) > 1e12:
            return None
        if np.linalg.norm(Y - X) <= 1e-11 * max(1.0, np.linalg.norm(Y)):
            return float(np.trace(Y))
        X = Y
    return None


def lower_trace(A, Q, q):
    n = A.shape[0]
    if q * max(abs(np.linalg.eigvals(A))) ** 2 >= 1:
        return None
    s = np.linalg.solve(np.eye(n * n) - q * np.kron(A, A), Q.reshape(-1, order="F"))
    return float(np.trace(s.reshape(n, n, order="F")))


def exact_rate_1d_blocks(A, sensors):
    """Shared-rate critical rate when all eigenvalues are real and distinct (1-D blocks)."""
    w, V = np.linalg.eig(A)
    if np.any(np.abs(w.imag) > 0) or len(set(np.round(np.abs(w), 9))) != len(w):
        return None
    worst = 0.0
    for i, lam in enumerate(w.real):
        if abs(lam) < 1:
            continue
        seeing = sum(1 for C, _, _ in sensors if np.linalg.norm(C @ V[:, i]) > 1e-9)
        if seeing == 0:
            return 1.0
        worst = max(worst, 1 - abs(lam) ** (-2.0 / seeing))
    return worst


def main():
    netkf, data = sys.argv[1], Path(sys.argv[2])
    failures = 0
    checked = 0
    for path in sorted(data.glob("*.yaml")):
        A, Q, sensors = load(path)
        if any(f.get("model") != "bernoulli" for _, _, f in sensors):
            continue
        rates = [1 - float(f["loss"]) for _, _, f in sensors]
        out = json.loads(subprocess.run([netkf, "analyze", str(path), "--json", "--no-lmi"], check=True,
                                        capture_output=True, text=True).stdout)
        ec = out["expected_covariance"]
        exp_lower = lower_trace(A, Q, float(np.prod([1 - r for r in rates])))
        exp_upper = upper_trace(A, Q, sensors, rates)
        def compare(name, got, expected, tol):
            nonlocal failures, checked
            checked += 1
            ok = (got is None and expected is None) or (
                got is not None and expected is not None and abs(got - expected) <= tol * max(1.0, abs(expected)))
            print(f"{'ok  ' if ok else 'FAIL'} {path.name}: {name} netkf={got} numpy={expected}")
            failures += 0 if ok else 1
        compare("Tr S-bar", ec["lower_trace"], exp_lower, 1e-9)
        compare("Tr V-bar", ec["upper_trace"], exp_upper, 1e-6)
        if out["critical_rate"] is not None:
            exact = exact_rate_1d_blocks(A, sensors)
            if exact is not None:
                compare("critical_rate.exact", out["critical_rate"]["exact"], exact, 1e-5)
    # docs/architecture.md contract: the keys exist; bad input gives a clear error and a non-zero status.
    keys = {"spectral_radius", "stable", "expected_covariance", "critical_rate", "markov_criterion", "notes"}
    for path in sorted(data.glob("*.yaml")):
        out = json.loads(subprocess.run([netkf, "analyze", str(path), "--json", "--no-lmi"], check=True,
                                        capture_output=True, text=True).stdout)
        checked += 1
        if not keys <= out.keys() or out["stable"] not in ("yes", "no", "unknown"):
            print(f"FAIL {path.name}: analyze --json keys {sorted(out.keys())}")
            failures += 1
    for bad in (data / "does-not-exist.yaml", Path(__file__)):
        for cmd in ("analyze", "simulate"):
            r = subprocess.run([netkf, cmd, str(bad), "--json"], capture_output=True, text=True)
            checked += 1
            if r.returncode == 0 or "error" not in r.stderr or r.stdout.strip():
                print(f"FAIL {cmd} {bad.name}: status {r.returncode}, stderr {r.stderr!r}")
                failures += 1
    print(f"{checked} comparisons, {failures} failures")
    return 1 if failures or checked == 0 else 0


if __name__ == "__main__":
    sys.exit(main())
