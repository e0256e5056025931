"""Benchmarks: each module runs as ``python -m pendulum_accel.bench.<name>`` and prints its figures."""
