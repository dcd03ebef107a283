"""Residual localisation, candidate physics, augmentation, verdicts."""
