"""Locate the mismatch between model and recording, name the missing physics, refit."""
