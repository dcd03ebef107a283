"""Batch runs of fit, diagnose and report on Dask distributed (`shockdyno batch`)."""
