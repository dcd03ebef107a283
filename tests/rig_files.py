"""Rig files for tests that must get as far as a command's connection and no further:
the simulated rig's file with its Modbus and serial ports where nothing answers."""

from __future__ import annotations

import socket
from pathlib import Path

SIM_RIG = Path(__file__).resolve().parents[1] / "rigs" / "sim.toml"


def closed_port() -> int:
    """A port on 127.0.0.1 that nothing listens on (bound, then let go)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def rig_on_closed_ports(folder: Path, simulated: bool = True) -> Path:
    """rigs/sim.toml pointing at closed ports, written into `folder`; without its
    [simulation] table (a real rig's file) unless `simulated`."""
    text = SIM_RIG.read_text()
    text = text.replace("port = 5020", f"port = {closed_port()}")
    text = text.replace("socket://127.0.0.1:5021", f"socket://127.0.0.1:{closed_port()}")
    if not simulated:
        text = text[: text.index("[simulation]")]
    path = folder / ("sim.toml" if simulated else "real.toml")
    path.write_text(text)
    return path
