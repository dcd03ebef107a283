"""Hardware contracts and drivers: Modbus actuator, serial DAQ, frame codec, rig config."""
