"""Benchmarks: speed against error for each scene kind."""
