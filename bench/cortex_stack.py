#!/usr/bin/env python3
"""The 32-bit firmware's stack high-water mark, in QEMU (`bash bench/firmware.sh` runs it).

The reset handler paints the free RAM with 0xA5A5A5A5 (firmware/cortex/src/start.rs). This
boots firmware/out/gweave-cortex.elf on QEMU's Netduino Plus 2, runs a working session over
the serial line (every report, moves, settings saved and read back, a checksum error), then
dumps the RAM through QEMU's monitor: the stack reached down to the lowest word that is no
longer the paint. Not a test: a figure for the budgets.
"""

import os
import socket
import subprocess
import sys
import tempfile
import time
from typing import Callable

RAM_START = 0x2000_0000
RAM_BYTES = 128 * 1024
PAINT = bytes.fromhex("a5a5a5a5")
SESSION = [
    "M115", "M105", "M119", "M503", "M92 X81", "M500", "M501", "M502", "G91",
    "G1 X10 Y5 Z1 F3000", "G1 X-5 Y-5 F6000", "M400", "M114", "N1 M105*0", "M110 N0",
    "M106 S128", "M107", "M104 S0", "G4 P10", "M400", "M114",
]


def main() -> None:
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    elf = sys.argv[1] if len(sys.argv) > 1 else os.path.join(root, "firmware/out/gweave-cortex.elf")
    with tempfile.TemporaryDirectory() as tmp:
        monitor = os.path.join(tmp, "monitor")
        dump = os.path.join(tmp, "ram.bin")
        qemu = subprocess.Popen(
            ["qemu-system-arm", "-M", "netduinoplus2", "-nographic", "-serial", "stdio",
             "-monitor", f"unix:{monitor},server,nowait", "-kernel", elf],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
        try:
            assert qemu.stdin and qemu.stdout
            wait_for(qemu, lambda line: line == "start")
            for line in SESSION:
                qemu.stdin.write(f"{line}\n".encode())
                qemu.stdin.flush()
                wait_for(qemu, lambda line: line == "ok" or line.startswith("ok "))
            with socket.socket(socket.AF_UNIX) as mon:
                mon.connect(monitor)
                # The file name is quoted: unquoted, its slashes would read as divisions.
                mon.sendall(f'pmemsave {RAM_START:#x} {RAM_BYTES} "{dump}"\n'.encode())
                for _ in range(100):
                    if os.path.exists(dump) and os.path.getsize(dump) == RAM_BYTES:
                        break
                    time.sleep(0.05)
            ram = open(dump, "rb").read()
        finally:
            qemu.kill()
            qemu.wait()
    # The paint runs from the end of .bss up; the first word above it that is not the paint is
    # as deep as the stack went.
    first_paint = next(i for i in range(0, RAM_BYTES, 4) if ram[i:i + 4] == PAINT)
    used = next(i for i in range(first_paint, RAM_BYTES, 4) if ram[i:i + 4] != PAINT)
    print(f"{'stack high-water mark':<26} {(RAM_BYTES - used) / 1024:7.1f} KB   "
          f"(a session of {len(SESSION)} commands; static RAM ends at {first_paint} bytes)")


def wait_for(qemu: "subprocess.Popen[bytes]", done: Callable[[str], bool]) -> None:
    """Read the serial line until `done` accepts a line."""
    assert qemu.stdout
    while True:
        line = qemu.stdout.readline()
        if not line:
            raise SystemExit("QEMU ended before the awaited reply")
        if done(line.decode().strip()):
            return


if __name__ == "__main__":
    main()
