"""Numba kernels: plain functions over ndarrays, floats, ints and bools only."""
