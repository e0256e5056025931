"""Benchmarks: each module is runnable with ``python -m pendulum_accel.bench.<name>`` and prints its figures."""
