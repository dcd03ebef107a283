"""shockdyno: shock-absorber dyno controller, MCAP logger and damper model."""

__version__ = "0.1.0"
