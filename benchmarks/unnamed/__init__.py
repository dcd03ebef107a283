"""Effects no term of the library has, added to the held-out plant (benchmarks/holdout),
for `bench_unnamed.py` and the tests of the diagnosis's discovered terms."""
