"""Simulated hardware on real wires: a Modbus server and a serial stream fed by the model."""
