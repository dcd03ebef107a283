"""`shockdyno compare`: recordings and fits side by side, differences judged against the
scatter the recordings themselves show (docs/compare.md)."""
