"""Error measures, objective, optimisers, calibration of globals, trends."""
