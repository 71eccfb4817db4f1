#!/usr/bin/env python3
"""Yardstick timings: Pinocchio (C++ via its Python bindings) on the same LWR 4+ model as
tools/gen_dynamics_fixtures.py, same state as dynamics/benches/dynamics.rs. Every figure includes
the Python call overhead, which is reported separately (a call of pin.neutral) so the C++ cost can
be estimated as (figure - overhead).

Usage: python3 tools/bench_pinocchio_dynamics.py
"""

import os
import statistics
import sys
import timeit

import numpy as np
import pinocchio as pin

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gen_dynamics_fixtures import build_model_a, load_links  # noqa: E402


def median_us(fn, number=20000, repeat=15):
    runs = timeit.repeat(fn, number=number, repeat=repeat)
    return statistics.median(runs) / number * 1e6


def main():
    model = build_model_a(load_links())
    data = model.createData()
    q = np.array([0.1, 0.5, -0.3, -1.2, 0.4, 0.9, -0.2])
    qd = np.array([0.3, -0.2, 0.5, 0.1, -0.4, 0.6, 0.2])
    qdd = np.array([1.0, -0.5, 0.2, 0.3, -0.1, 0.4, 0.7])
    tau = pin.rnea(model, data, q, qd, qdd).copy()
    rows = [
        ("python call overhead (pin.neutral)", lambda: pin.neutral(model)),
        ("rnea", lambda: pin.rnea(model, data, q, qd, qdd)),
        ("computeGeneralizedGravity", lambda: pin.computeGeneralizedGravity(model, data, q)),
        ("crba", lambda: pin.crba(model, data, q)),
        ("nonLinearEffects", lambda: pin.nonLinearEffects(model, data, q, qd)),
        ("computeCoriolisMatrix", lambda: pin.computeCoriolisMatrix(model, data, q, qd)),
        ("computeJointTorqueRegressor (7x70)",
         lambda: pin.computeJointTorqueRegressor(model, data, q, qd, qdd)),
        ("aba (forward dynamics)", lambda: pin.aba(model, data, q, qd, tau)),
    ]
    print(f"pinocchio {pin.__version__}, numpy {np.__version__}; median per call, us")
    for name, fn in rows:
        print(f"{name:40s} {median_us(fn):8.3f}")


if __name__ == "__main__":
    main()
