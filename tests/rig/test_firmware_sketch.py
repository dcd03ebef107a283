"""The reference DAQ firmware in docs/daq-firmware.md, compiled from the page and decoded by
frames.py.

The sketch's frame builder is plain C++ (its Arduino part sits behind `#ifdef ARDUINO`),
so the host's compiler builds it with a small main that writes frames for known values;
the decoder must return exactly those values. Skipped without a C++ compiler.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from shockdyno.rig import frames
from shockdyno.rig.frames import FrameDecoder

DOC = Path(__file__).resolve().parents[2] / "docs" / "daq-firmware.md"
N = 300


def sketch() -> str:
    text = DOC.read_text()
    m = re.search(r"<!-- firmware-sketch -->\s*```cpp\n(.*?)```", text, re.S)
    assert m, "docs/daq-firmware.md lost its firmware sketch"
    return m.group(1)


def test_sketch_constants_match_the_decoder() -> None:
    code = sketch()

    def const(name: str) -> int:
        m = re.search(rf"\b{name} = (0x[0-9A-Fa-f]+|\d+u? << \d+|\d+);", code)
        assert m, name
        value = m.group(1)
        if "<<" in value:
            base, shift = value.split("<<")
            return int(base.strip().rstrip("u")) << int(shift)
        return int(value, 0)

    assert bytes([const("SYNC0"), const("SYNC1")]) == frames.SYNC
    assert const("FRAME_LEN") == frames.FRAME_LEN
    for name in ("STATUS_MOTION", "STATUS_LOAD_OVERRANGE", "STATUS_LVDT_OVERRANGE",
                 "STATUS_TEMP_FAULT"):  # fmt: skip
        assert const(name) == getattr(frames, name), name


HOST_MAIN = f"""
#include <cstdio>
int main() {{
  uint8_t f[FRAME_LEN];
  for (int i = 0; i < {N}; i++) {{
    build_frame(f, (uint16_t)(65400 + i), -2000000 + 12345 * i, 70000 + 37 * i,
                (int16_t)(-300 + 17 * i), (uint16_t)(i % 16));
    fwrite(f, 1, FRAME_LEN, stdout);
  }}
  return 0;
}}
"""


def test_sketch_frames_decode_to_what_it_sent(tmp_path: Path) -> None:
    cxx = shutil.which("c++") or shutil.which("g++") or shutil.which("clang++")
    if cxx is None:
        pytest.skip("no C++ compiler")
    src = tmp_path / "sketch.cpp"
    src.write_text(sketch() + HOST_MAIN)
    exe = tmp_path / "sketch"
    subprocess.run([cxx, "-std=c++11", "-Wall", "-Werror", "-o", str(exe), str(src)],
                   check=True, capture_output=True, timeout=60)  # fmt: skip
    data = subprocess.run([str(exe)], check=True, capture_output=True, timeout=10).stdout
    assert len(data) == N * frames.FRAME_LEN
    dec = FrameDecoder()
    got = dec.feed(data[:1000])  # split mid-frame, as a serial read would
    rest = dec.feed(data[1000:])
    i = np.arange(N)
    assert dec.frames == N and dec.corrupt_frames == 0 and dec.dropped_frames == 0
    np.testing.assert_array_equal(np.concatenate([got.seq, rest.seq]), 65400 + i)  # unwrapped
    np.testing.assert_array_equal(np.concatenate([got.load, rest.load]), -2000000 + 12345 * i)
    np.testing.assert_array_equal(np.concatenate([got.lvdt, rest.lvdt]), 70000 + 37 * i)
    np.testing.assert_array_equal(np.concatenate([got.temp, rest.temp]), -300 + 17 * i)
    np.testing.assert_array_equal(np.concatenate([got.status, rest.status]), i % 16)
    # And byte for byte what the simulated DAQ's encoder sends for the same samples.
    assert data == frames.encode_frames(
        65400 + i, -2000000 + 12345 * i, 70000 + 37 * i, -300 + 17 * i, i % 16
    )


ARDUINO_STUBS = """
#include <stdint.h>
#include <stddef.h>
#define INPUT 0
uint32_t micros();
void pinMode(int, int);
int digitalRead(int);
struct SerialPort {
  void begin(unsigned long);
  int availableForWrite();
  size_t write(const uint8_t *, size_t);
};
extern SerialPort Serial;
"""


def test_sketch_arduino_part_compiles(tmp_path: Path) -> None:
    """The setup()/loop() half against the Arduino API's signatures (syntax and types)."""
    cxx = shutil.which("c++") or shutil.which("g++") or shutil.which("clang++")
    if cxx is None:
        pytest.skip("no C++ compiler")
    src = tmp_path / "arduino.cpp"
    src.write_text(ARDUINO_STUBS + sketch())
    done = subprocess.run([cxx, "-std=c++11", "-DARDUINO", "-Wall", "-Werror", "-fsyntax-only",
                           str(src)], capture_output=True, text=True, timeout=60)  # fmt: skip
    assert done.returncode == 0, done.stderr
