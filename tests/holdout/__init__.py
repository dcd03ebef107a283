"""Held-out test plant for `shockdyno diagnose`: a monotube damper on a dyno written
independently of the project's model (plant.py, sweep.py). The suite diagnoses it
(tests/diagnose/test_diagnose_holdout.py); benchmarks/bench_holdout.py and
benchmarks/bench_reference.py --plant holdout score it."""
