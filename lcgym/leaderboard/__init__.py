"""Metrics (MA, RMS, Inf), and later the benchmark runner, results store and report."""
