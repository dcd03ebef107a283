"""Held-out test plant for `shockdyno diagnose`: a monotube damper on a dyno written
independently of the project's model (see plant.py, sweep.py and ../bench_holdout.py)."""
