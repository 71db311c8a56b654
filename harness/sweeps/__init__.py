"""Robustness sweeps: a spec of conditions x seeds x system configurations, one run per condition and
seed (locally or on a Dask cluster), runs.csv and its report."""
