"""The command line's glue: each module registers its subcommands (`register(subparsers)`)
and turns their arguments into calls of the layers below, with progress, files and
one-line errors. Only this layer may import every other (docs/architecture.md, checked
by tests/test_layering.py); nothing but `shockdyno.cli` imports it."""
