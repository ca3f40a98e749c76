"""Running cases: one case on a worker, the dask fan-out with progress, the ledger that lets a study resume."""
