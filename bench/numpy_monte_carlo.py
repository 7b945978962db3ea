#!/usr/bin/python3
"""Vectorised NumPy Monte Carlo of the intermittent Kalman filter, the same simulation as
`netkf simulate` / bench_monte_carlo (error dynamics, Bernoulli links, sequential Joseph
updates), vectorised over runs. Prints filter steps per second (runs * steps / wall time).
Run as shipped (Debian python3-numpy, its default BLAS): bench/numpy_monte_carlo.py [runs] [steps]
"""
import sys
import time

import numpy as np


def simulate_scalar(a, q, c, r, lam, runs, steps, rng):
    # n = 1, one sensor: plain float vectors over runs (the fastest NumPy form).
    e = rng.standard_normal(runs)
    P = np.ones(runs)
    sq, sr = np.sqrt(q), np.sqrt(r)
    for k in range(steps):
        arrived = rng.random(runs) < lam
        K = np.where(arrived, P * c / (c * c * P + r), 0.0)
        e = e - K * (c * e + sr * rng.standard_normal(runs))
        P = (1 - K * c) ** 2 * P + r * K * K
        if k + 1 < steps:
            e = a * e + sq * rng.standard_normal(runs)
            P = a * a * P + q
    return float(P.mean()), float((e ** 2).mean())


def simulate(A, Q, Cs, Rs, rates, runs, steps, rng):
    n = A.shape[0]
    if n == 1 and len(Cs) == 1:
        return simulate_scalar(A[0, 0], Q[0, 0], Cs[0][0, 0], Rs[0], rates[0], runs, steps, rng)
    Qr = np.linalg.cholesky(Q)
    e = rng.standard_normal((runs, n))                      # e_0 ~ N(0, I) (P0 = I)
    P = np.broadcast_to(np.eye(n), (runs, n, n)).copy()
    I = np.eye(n)
    for k in range(steps):
        for C, R, lam in zip(Cs, Rs, rates):
            arrived = rng.random(runs) < lam
            c = C[0]
            Pc = P @ c                                         # (runs, n)
            s = Pc @ c + R                                     # innovation variance
            K = Pc / s[:, None]
            K[~arrived] = 0.0                                  # no update where the sample was lost
            v = np.sqrt(R) * rng.standard_normal(runs)
            e = e - K * ((e @ c) + v)[:, None]                 # e+ = (I - K c) e - K v
            IKc = I - K[:, :, None] * c[None, None, :]
            P = IKc @ P @ IKc.transpose(0, 2, 1) + R * K[:, :, None] * K[:, None, :]
        trace = np.trace(P, axis1=1, axis2=2)
        if k + 1 < steps:
            e = e @ A.T + rng.standard_normal((runs, n)) @ Qr.T
            P = A @ P @ A.T + Q
    return float(trace.mean()), float((e ** 2).sum(axis=1).mean())


def scenarios():
    scalar = (np.array([[-1.25]]), np.array([[1.0]]), [np.array([[1.0]])], [2.5], [0.6])
    A6 = np.array([[1.05, 0.2, 0, 0, 0, 0], [-0.2, 1.05, 0, 0, 0, 0], [0, 0, 1.1, 0.1, 0, 0],
                   [0, 0, 0, 0.9, 0.3, 0], [0, 0, 0, 0, 0.8, 0.1], [0, 0, 0, 0, 0, 0.7]])
    Cs = [np.array([[1, 0, 0, 0, 0, 0.]]), np.array([[0, 1, 1, 0, 0, 0.]]),
          np.array([[0, 0, 1, 1, 0, 0.]]), np.array([[0, 0, 0, 0, 1, 1.]])]
    six = (A6, np.eye(6), Cs, [1.0] * 4, [0.8] * 4)
    return {"scalar (sinopoli-scalar, lambda 0.6)": scalar, "6-state, 4-sensor (lambda 0.8)": six}


def main():
    runs = int(sys.argv[1]) if len(sys.argv) > 1 else 20000
    steps = int(sys.argv[2]) if len(sys.argv) > 2 else 300
    runs_six = int(sys.argv[3]) if len(sys.argv) > 3 else 2000
    rng = np.random.default_rng(42)
    for (name, (A, Q, Cs, Rs, rates)), r in zip(scenarios().items(), (runs, runs_six)):
        runs = r
        t0 = time.perf_counter()
        tr, err = simulate(A, Q, Cs, Rs, rates, runs, steps, rng)
        dt = time.perf_counter() - t0
        print(f"{name}: {runs} runs x {steps} steps in {dt:.3f} s = {runs * steps / dt / 1e6:.2f} M filter-steps/s"
              f" (mean Tr P {tr:.4g}, mean |e|^2 {err:.4g})")


if __name__ == "__main__":
    main()
