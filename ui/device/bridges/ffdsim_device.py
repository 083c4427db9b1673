#!/usr/bin/env python3
"""ffdsim device link, reference bridge for Python (standard library only).

Copy this file beside your device's Python bindings and, every millisecond, send the
device's pose and apply the newest force ffdsim sent back (docs/realtime.md, "Haptic devices"):

    link = Link("127.0.0.1", 47000)             # where `ffdsim run --device` listens
    link.send(x, y, z)                          # metres, in the scene's frame
    force = link.newest_force()                 # a Force, or None if nothing new
    if force: set_device_force(force.force)     # newtons

Wire format: version 1, 80-byte messages, little-endian (ui/device/device_protocol.h).
Run as a program it is a pretend device: the probe circles above a point for a few seconds.
"""
import argparse
import math
import socket
import struct
import sys
import time
from typing import NamedTuple, Optional

VERSION = 1
MESSAGE_SIZE = 80
SAMPLE = struct.Struct("<4sHHIIQ3d4d")   # magic, version, kind, sequence, buttons, device time, position, orientation
FORCE = struct.Struct("<4sHHIIQQ3d3d")   # magic, version, kind, sequence, status, device time, step, force, torque

FORCE_LIVE, FORCE_WATCHDOG, FORCE_LIMITED, FORCE_RATE_LIMITED, FORCE_REENGAGING = 1, 2, 4, 8, 16


class Force(NamedTuple):
    sample_sequence: int
    status: int
    sample_device_time_us: int
    step: int
    force: tuple
    torque: tuple


def encode_sample(sequence, device_time_us, position, orientation=(1.0, 0.0, 0.0, 0.0), buttons=0):
    return SAMPLE.pack(b"FFDS", VERSION, 1, sequence & 0xFFFFFFFF, buttons, device_time_us, *position, *orientation)


def decode_force(data) -> Optional[Force]:
    if len(data) != MESSAGE_SIZE:
        return None
    magic, version, kind, sequence, status, device_time, step, *values = FORCE.unpack(data)
    if magic != b"FFDF" or version != VERSION or kind != 2:
        return None
    return Force(sequence, status, device_time, step, tuple(values[:3]), tuple(values[3:]))


class Link:
    """A UDP socket to ffdsim: send() never blocks, newest_force() reads what has arrived."""

    def __init__(self, host="127.0.0.1", port=47000):
        self.socket = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.socket.connect((host, port))
        self.socket.setblocking(False)
        self.sequence = 0
        self.epoch = time.monotonic_ns()

    def send(self, x, y, z, orientation=(1.0, 0.0, 0.0, 0.0), buttons=0):
        message = encode_sample(self.sequence, (time.monotonic_ns() - self.epoch) // 1000, (x, y, z), orientation, buttons)
        self.sequence += 1
        try:
            self.socket.send(message)
        except OSError:
            pass  # ffdsim not listening (yet): the next sample tries again

    def newest_force(self) -> Optional[Force]:
        newest = None
        while True:
            try:
                data = self.socket.recv(2 * MESSAGE_SIZE)
            except (BlockingIOError, ConnectionRefusedError):
                return newest
            force = decode_force(data)
            if force and (newest is None or force.step > newest.step):
                newest = force

    def close(self):
        self.socket.close()


def main():
    parser = argparse.ArgumentParser(description="A pretend haptic device on ffdsim's device link.")
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, default=47000)
    parser.add_argument("--seconds", type=float, default=2.0)
    parser.add_argument("--centre", type=float, nargs=3, default=(0.0, 0.12, 0.0), metavar=("X", "Y", "Z"))
    parser.add_argument("--encode-example", action="store_true",
                        help="print the hex of sample 7 at 1234 us, position (0.1, 0.2, 0.3), and exit")
    args = parser.parse_args()
    if args.encode_example:
        print(encode_sample(7, 1234, (0.1, 0.2, 0.3)).hex())
        return 0
    link = Link(args.host, args.port)
    forces, largest, last = 0, 0.0, None
    start = time.monotonic()
    for ms in range(int(args.seconds * 1000)):
        t = ms * 1e-3
        cx, cy, cz = args.centre
        link.send(cx + 0.02 * math.cos(6.0 * t), cy + 0.02, cz + 0.02 * math.sin(6.0 * t))
        force = link.newest_force()
        if force:
            forces += 1
            last = force
            largest = max(largest, math.sqrt(sum(f * f for f in force.force)))
        time.sleep(max(0.0, start + (ms + 1) * 1e-3 - time.monotonic()))
    link.close()
    print(f"ffdsim_device.py: {link.sequence} samples sent, forces on {forces} ticks, largest {largest:.3f} N, "
          f"last from step {last.step if last else 0}")
    return 0 if forces > 0 else 3


if __name__ == "__main__":
    sys.exit(main())
