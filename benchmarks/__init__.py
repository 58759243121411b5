"""Benchmarks: run all with `.venv/bin/python -m benchmarks`, one with `-m benchmarks.bench_X`."""
