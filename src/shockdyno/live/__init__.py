"""The live view of a sweep or a replay in Foxglove (`--live`; docs/live.md)."""
