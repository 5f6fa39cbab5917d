"""`gweave serve` driven by a real host: Printrun's printcore over a pty, with a noisy wire.

printcore streams a real PrusaSlicer file with line numbers and checksums. A wrapper around its
serial write corrupts a few lines on their first sending (a flipped checksum, a wrong line
number, a lost byte) and sends one line twice. The test checks that every line written got
exactly one `ok`, that each error was answered with Marlin's exact `Error:` and `Resend:` lines,
and that the machine ends where the simulator says the same file ends: the final `M114`, the
position and the filament per tool of the session report.

printcore is installed without its GUI dependencies (wxPython has no Linux wheel):
`pip install --no-deps -r crates/gweave-py/requirements-host.txt` (Printrun) plus pyserial from
requirements-dev.txt. Everything runs on loopback, bounded by timeouts.
"""

import json
import os
import re
import select
import subprocess
import time
from pathlib import Path

import pytest
from _host import gweave_command, wait_for

printcore_mod = pytest.importorskip(
    "printrun.printcore", reason="pip install --no-deps -r crates/gweave-py/requirements-host.txt"
)
gcoder = pytest.importorskip("printrun.gcoder")

FIXTURE = ("prusaslicer", "pr_torus_pva.gcode")
NUMBERED = re.compile(r"N(-?\d+) (.*)\*(\d+)\n")



@pytest.fixture(scope="module", autouse=True)
def serve_is_wired():
    """`gweave serve` needs the interpreter (`gweave_sim::interp`); skip until it is built in."""
    r = subprocess.run(gweave_command() + ["serve", "--help"], capture_output=True, text=True, timeout=60)
    if r.returncode != 0:
        pytest.skip("this gweave has no `serve` subcommand yet")



def checksum(text: str) -> int:
    value = 0
    for byte in text.encode():
        value ^= byte
    return value


class Server:
    """`gweave serve --pty` in a subprocess, stopped with SIGTERM."""

    def __init__(self, tmp: Path, name: str):
        self.link = tmp / name
        self.report = tmp / f"{name}.json"
        self.log = tmp / f"{name}.log"
        args = ["serve", "--pty", str(self.link), "--report", str(self.report), "--log", str(self.log)]
        # The idle limit ends a server the test forgot, the timeouts below end a stuck test.
        args += ["--exit-after-idle", "120"]
        self.proc = subprocess.Popen(gweave_command() + args, stderr=subprocess.PIPE, text=True)
        wait_for(lambda: self.link.is_symlink() or self.proc.poll() is not None, 30, "the pty link")
        assert self.proc.poll() is None, self.proc.stderr.read()

    def session_report(self) -> dict:
        """The report written when the host disconnected."""
        wait_for(self.report.exists, 30, "the session report")
        time.sleep(0.2)
        return json.loads(self.report.read_text())

    def stop(self) -> str:
        self.proc.terminate()
        _, err = self.proc.communicate(timeout=10)
        assert self.proc.returncode == 0, err
        assert not self.link.is_symlink(), "the link is removed on SIGTERM"
        return err


def reference_report(tmp: Path, source: Path) -> dict:
    """What the simulator reports for the file: `gweave sim --report` when the CLI has it, else
    the report of a clean session that writes the file line by line without a host library."""
    out = tmp / "sim.json"
    command = gweave_command() + ["sim", str(source), "--report", str(out)]
    r = subprocess.run(command, capture_output=True, text=True, timeout=300)
    if r.returncode == 0:
        return json.loads(out.read_text())
    server = Server(tmp, "clean")
    try:
        fd = os.open(server.link, os.O_RDWR | os.O_NOCTTY)
        pending = b""

        def read_line() -> bytes:
            nonlocal pending
            while b"\n" not in pending:
                ready, _, _ = select.select([fd], [], [], 30)
                assert ready, "no reply within 30 s"
                pending += os.read(fd, 65536)
            line, pending = pending.split(b"\n", 1)
            return line

        try:
            for line in source.read_text().splitlines():
                command = line.split(";", 1)[0].strip()
                if command:
                    os.write(fd, command.encode() + b"\n")
                    while not read_line().startswith(b"ok"):
                        pass
        finally:
            os.close(fd)
        return server.session_report()
    finally:
        server.stop()


def test_printcore_streams_a_fixture_through_a_noisy_wire(data, tmp_path):
    source = data.joinpath(*FIXTURE)
    reference = reference_report(tmp_path, source)
    server = Server(tmp_path, "gweave0")
    received = []
    host = printcore_mod.printcore()
    host.recvcb = lambda line: received.append(line.rstrip("\r\n"))
    try:
        host.connect(str(server.link), 115200)
        wait_for(lambda: host.online, 30, "printcore to see the printer online")
        # The handshake's M105 answer comes after `start`; count from after it.
        wait_for(lambda: any(l.startswith("ok") for l in received), 10, "the handshake ok")
        mark = len(received)

        writes = []
        faults = {}
        original = host.printer.write

        def noisy(raw: bytes):
            text = raw.decode()
            m = NUMBERED.fullmatch(text)
            n = int(m[1]) if m else None
            if n in (50, 120, 300, 400) and n not in faults:
                faults[n] = text
                if n == 50:  # a flipped checksum digit
                    text = f"N{n} {m[2]}*{(int(m[3]) + 1) % 256}\n"
                elif n == 120:  # a line number from the future, with a valid checksum
                    body = f"N{n + 2} {m[2]}"
                    text = f"{body}*{checksum(body)}\n"
                elif n == 300:  # a byte lost on the wire
                    text = text[:4] + text[5:]
                elif n == 400:  # the same line twice
                    writes.append(text)
                    original(raw)
            writes.append(text)
            original(text.encode())

        host.printer.write = noisy
        lines = source.read_text().splitlines()
        host.startprint(gcoder.LightGCode(lines))
        wait_for(lambda: not host.printing, 600, "the print to end")
        host.send_now("M114")
        wait_for(lambda: any(l.startswith("X:") for l in received[mark:]), 30, "the M114 answer")
        oks = lambda: sum(1 for l in received[mark:] if l.startswith("ok"))
        wait_for(lambda: oks() >= len(writes), 30, "an ok for every line written")
        time.sleep(0.3)
    finally:
        host.disconnect()
    report = server.session_report()
    err = server.stop()

    # Every line written got exactly one ok: the corrupted ones, the resent ones, the duplicate.
    assert oks() == len(writes), (oks(), len(writes))
    replies = received[mark:]
    for error, resend in [
        ("Error:checksum mismatch, Last Line: 49", "Resend: 50"),
        ("Error:Line Number is not Last Line Number+1, Last Line: 119", "Resend: 120"),
        ("Error:checksum mismatch, Last Line: 299", "Resend: 300"),
    ]:
        i = replies.index(error)
        assert replies[i + 1 : i + 3] == [resend, "ok"], replies[i : i + 3]
    # printcore takes both the `Resend:` and its `ok` as clearance to send, so after an error it
    # may have two lines in flight: the second then draws a line-number error of its own and is
    # sent again, and its repeat is acknowledged as a duplicate. Every error asks for a resend.
    resends = [l for l in replies if l.startswith("Resend:")]
    assert len(resends) >= 3 and len(resends) == sum(1 for l in replies if l.startswith("Error:"))
    # Each corrupted line went out again intact; the doubled one twice.
    for n in (50, 120, 300):
        assert writes.count(faults[n]) >= 1, n
    assert writes.count(faults[400]) >= 2
    refused, duplicates = map(int, re.search(r"(\d+) refused with a resend or error, (\d+) duplicates", err).groups())
    assert refused == len(resends) and duplicates >= 1, err

    # The machine ends where the simulator says the file ends.
    # Every line of the file went out under its own number.
    sent = {int(NUMBERED.fullmatch(w)[1]) for w in writes if NUMBERED.fullmatch(w) and "M110" not in w}
    body_lines = [l.split(";", 1)[0].strip() for l in source.read_text().splitlines()]
    assert sent == set(range(sum(1 for l in body_lines if l)))
    m114 = next(l for l in replies if l.startswith("X:"))
    x, y, z, e = reference["position"][:4]
    assert m114.startswith(f"X:{x:.2f} Y:{y:.2f} Z:{z:.2f} E:{e:.2f} Count"), (m114, reference["position"])
    assert report["position"] == pytest.approx(reference["position"], abs=1e-9)
    assert report["filament_mm"] == pytest.approx(reference["filament_mm"], abs=1e-9)
    assert report["count"] == reference["count"]
    assert sum(reference["filament_mm"]) > 500
