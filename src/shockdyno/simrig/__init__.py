"""Simulated hardware on real wires: a Modbus server and a serial stream fed by the model."""

from shockdyno.simrig.faults import Fault, parse_fault
from shockdyno.simrig.server import SimRig, start_sim_rig

__all__ = ["Fault", "SimRig", "parse_fault", "start_sim_rig"]
