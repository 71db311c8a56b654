"""Measuring and reporting a run: metrics against ground truth, typed results, report.md and its
PNG panels, and comparing two runs' metrics."""
