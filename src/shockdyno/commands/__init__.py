"""The command line's glue: each module registers its subcommands (`register(subparsers)`)
and turns their arguments into calls of the layers below, with progress, files and
one-line errors. Only this layer may import every other (docs/architecture.md, checked
by tests/test_layering.py); nothing but `shockdyno.cli` imports it.

Imports are at the top of each module but where one would cost every command's start-up
5 ms CPU or more (matplotlib's 430-620 ms, a rig command's own 8-28 ms, the live view's,
replay's and batch's 7 ms): those are imported in the function that needs them, each with
its figure (benchmarks/bench_startup.py; benchmarks/results/startup-2026-11-29.txt)."""
