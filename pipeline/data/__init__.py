"""Datasets: netCDF (CF-1.8) writing and reading, each kind's run and fly datasets, studies, profiles, queries."""
