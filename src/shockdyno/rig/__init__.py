"""Hardware contracts and drivers: Modbus actuator, serial DAQ, frame codec, rig config."""

from shockdyno.rig.config import RigConfig, load_rig
from shockdyno.rig.types import Adjuster, Daq
from shockdyno.samples import SampleBlock

__all__ = ["Adjuster", "Daq", "RigConfig", "SampleBlock", "load_rig"]
