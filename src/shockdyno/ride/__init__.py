"""Ride study: the quarter car on ISO 8608 roads with the fitted damper (docs/ride.md)."""

from shockdyno.ride.study import RideConfig, RideResult, Run, run_study

__all__ = ["RideConfig", "RideResult", "Run", "run_study"]
