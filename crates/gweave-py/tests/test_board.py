"""The gweave firmware on the emulated RAMPS board, driven by a real host over a pty.

`gweave-board firmware/out/gweave-ramps.elf --pty LINK` runs the very image `make firmware`
builds on an emulated ATmega2560 (libsimavr) wired as a printer; Printrun's printcore streams
the start of a real Cura file to it with line numbers and checksums. The board's pins must end
where the firmware's own planner says and where the same core on the host (`gweave sim` with
`[firmware] kind = "gweave"`) ends: the X, Y and Z positions counted on the STEP and DIR pins
(microsteps from the endstops the file's G28 homed against) equal the `Count` of the final
`M114` and the twin's end steps, exactly. A second test prints the same file from OctoPrint's
storage through its REST API, and the pins end on the same steps.

Needs `make firmware` and the `gweave-board` binary (`cargo build -p gweave-board`; $GWEAVE_BOARD
names it, as `make pytest` does).
"""

import json
import os
import re
import signal
import subprocess
import time
from pathlib import Path

import pytest
from _host import gweave_command, wait_for

printcore_mod = pytest.importorskip(
    "printrun.printcore", reason="pip install --no-deps -r crates/gweave-py/requirements-host.txt"
)
gcoder = pytest.importorskip("printrun.gcoder")

ROOT = Path(__file__).resolve().parents[3]
ELF = ROOT / "firmware" / "out" / "gweave-ramps.elf"
# Moves of the first layer streamed: enough for every kind of move (travel, print, retract), few
# enough for a few seconds of emulation.
MOVES = 300
# Heating is proven by the board's own tests (crates/gweave-board/tests/board/heating.rs); here
# the bed would only add minutes of emulated waiting, and the hotend starts hot (--hotend-c) so
# that the file's own M109 returns at once and the extruder may move.
BED_HEATING = re.compile(r"^M(140|190)\b")


def board_binary() -> Path:
    named = os.environ.get("GWEAVE_BOARD")
    if named:
        assert Path(named).exists(), f"GWEAVE_BOARD={named} does not exist"
        return Path(named)
    built = ROOT / "target" / "debug" / "gweave-board"
    if not built.exists() or not ELF.exists():
        pytest.skip("make firmware and cargo build -p gweave-board first")
    return built



def twin_end_steps(cut: Path, tmp: Path) -> list:
    """Where the same file ends on the controller core's twin on the host (`gweave sim` with the
    firmware's default printer), in steps per axis."""
    report = tmp / "twin.json"
    machine = ROOT / "examples" / "machines" / "gweave-ramps.toml"
    command = gweave_command() + ["sim", str(cut), "--machine", str(machine), "--report", str(report)]
    r = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    return json.loads(report.read_text())["end_steps"]



def first_moves(source: Path, moves: int) -> list:
    """The file's start, up to `moves` moves into the first layer, without the bed's heating."""
    out, in_layer, count = [], False, 0
    for line in source.read_text().splitlines():
        if BED_HEATING.match(line):
            continue
        out.append(line)
        in_layer = in_layer or line.startswith(";LAYER:0")
        if in_layer and line.startswith(("G0 ", "G1 ")):
            count += 1
            if count == moves:
                break
    return out


def start_board(binary: Path, tmp: Path, extra: list) -> tuple:
    """Starts the board on the pty `tmp/ramps` with a hot hotend, as fast as it can run; returns
    the process once the link is there, and the file its messages go to."""
    link, log = tmp / "ramps", tmp / "board.log"
    args = ["--pty", str(link), "--fast", "--hotend-c", "214", *extra]
    with open(log, "w") as err:
        proc = subprocess.Popen([str(binary), str(ELF), *args], stdout=subprocess.DEVNULL, stderr=err)
    try:
        wait_for(lambda: link.is_symlink() or proc.poll() is not None, 30, "the pty link")
        assert proc.poll() is None, log.read_text()
    except BaseException:
        stop_board(proc)
        raise
    return proc, log


def stop_board(proc: subprocess.Popen) -> None:
    """Ends the board if it still runs, and reaps it (a test that failed midway leaves no process
    behind for a later test's garbage collector to warn about)."""
    if proc.poll() is None:
        proc.kill()
    proc.wait(timeout=30)


def test_ctrl_c_ends_the_board_and_removes_its_link(tmp_path):
    """Regression (a new user's trial: Ctrl-C or a TERM killed `gweave-board` and left its pty
    link behind, pointing at a terminal that no longer exists): the board ends with status 0 and
    the link is gone."""
    for sig in (signal.SIGINT, signal.SIGTERM):
        proc, log = start_board(board_binary(), tmp_path, ["--seconds", "600"])
        try:
            proc.send_signal(sig)
            assert proc.wait(timeout=30) == 0, log.read_text()
            assert not (tmp_path / "ramps").is_symlink()
        finally:
            stop_board(proc)


def test_board_keeps_running_when_a_host_probes_the_port_without_a_byte(tmp_path):
    """Regression (CI, stop 41): Printrun runs `stty -F PORT -hup` before it opens the port; the
    board took that open and close for the end of a session, wrote its report and exited, and
    printcore then found no port ("Could not connect to serial port")."""
    binary = board_binary()
    link, report = tmp_path / "ramps", tmp_path / "pins.json"
    proc, log = start_board(binary, tmp_path, ["--report", str(report), "--seconds", "600"])
    try:
        for _ in range(3):
            probe = subprocess.run(["stty", "-F", str(link), "-hup"], capture_output=True, text=True)
            assert probe.returncode == 0, probe.stderr
            time.sleep(0.3)
        assert proc.poll() is None, log.read_text()
        assert link.is_symlink() and not report.exists()
        # A host that does speak ends the session: the report is written and the board exits.
        answer = bytearray()

        def answered(word: bytes) -> bool:
            answer.extend(os.read(host.fileno(), 4096))
            return word in answer

        with open(link, "r+b", buffering=0) as host:
            # Opening the port resets the board; what it receives before its greeting is lost,
            # as on a real Mega, so a host waits for `start` first.
            wait_for(lambda: answered(b"start"), 30, "the board's greeting")
            host.write(b"M114\n")
            wait_for(lambda: answered(b"Count"), 30, "the M114 answer")
        wait_for(report.exists, 30, "the board's report")
        assert proc.wait(timeout=30) == 0, log.read_text()
    finally:
        stop_board(proc)


def test_printcore_streams_a_cura_file_and_the_pins_agree_with_m114(data, tmp_path):
    binary = board_binary()
    lines = first_moves(data / "cura" / "cura_torus.gcode", MOVES)
    cut = tmp_path / "cut.gcode"
    cut.write_text("\n".join(lines) + "\n")
    link, report = tmp_path / "ramps", tmp_path / "pins.json"
    proc, log = start_board(binary, tmp_path, ["--report", str(report), "--seconds", "600"])
    received = []
    host = printcore_mod.printcore()
    host.recvcb = lambda line: received.append(line.rstrip("\r\n"))
    try:
        host.connect(str(link), 250000)
        wait_for(lambda: host.online, 30, "printcore to see the board online")
        host.startprint(gcoder.LightGCode(lines))
        wait_for(lambda: not host.printing, 300, "the print to end")
        host.send_now("M400")
        host.send_now("M114")
        wait_for(lambda: any(" Count " in l for l in received), 60, "the M114 answer")
        host.disconnect()
        wait_for(report.exists, 30, "the board's report")
        proc.wait(timeout=30)
    except BaseException:
        print("board log:", log.read_text())
        raise
    finally:
        host.disconnect()
        stop_board(proc)
    pins = json.loads(report.read_text())

    # Not one error or resend (printcore's opening `N-1 M110 N-1` included).
    assert not [l for l in received if l.startswith(("Error:", "Resend:", "!!"))], received
    m114 = next(l for l in received if " Count " in l)
    count = dict(re.findall(r"([XYZ]):(-?\d+)", m114.split(" Count ", 1)[1]))
    # The pins, microsteps from the endstops: where the firmware's planner says it is.
    assert pins["position_steps"][:3] == [int(count[a]) for a in "XYZ"], (pins, m114)
    # The same core on the host ends on the same steps.
    assert pins["position_steps"][:3] == twin_end_steps(cut, tmp_path)[:3], pins
    # The file printed something: the head moved and the extruder pushed filament.
    assert min(abs(p) for p in pins["position_steps"][:2]) > 1000, pins
    assert pins["net_steps"][3] > 0, pins


def test_octoprint_prints_a_cura_file_on_the_board_and_the_pins_agree_with_the_twin(data, tmp_path):
    """The same file printed from OctoPrint's storage through its REST API, as a user does."""
    pytest.importorskip("octoprint", reason="pip install -r crates/gweave-py/requirements-octoprint.txt")
    from test_octoprint_serve import OctoPrint, connect

    binary = board_binary()
    cut = tmp_path / "cut.gcode"
    cut.write_text("\n".join(first_moves(data / "cura" / "cura_torus.gcode", MOVES)) + "\n")
    link, report = tmp_path / "ramps", tmp_path / "pins.json"
    octo = None
    proc, log = start_board(binary, tmp_path, ["--report", str(report), "--seconds", "900"])
    try:
        octo = OctoPrint(tmp_path, link)
        connect(octo, str(link))
        octo.upload("local", cut, select="true", print="true")
        wait_for(lambda: octo.job()["state"].startswith("Printing"), 30, "the print to start")
        wait_for(lambda: octo.job()["state"] == "Operational", 300, "the print to end")
        assert octo.job()["progress"]["completion"] == 100.0
        # The moves still queued end before the M114 is answered.
        answers = octo.serial_log().count(" Count ")
        octo.post("/api/printer/command", {"commands": ["M400", "M114"]})
        wait_for(lambda: octo.serial_log().count(" Count ") > answers, 60, "the M114 after the moves")
        octo.post("/api/connection", {"command": "disconnect"})
        wait_for(report.exists, 30, "the board's report")
    finally:
        if octo is not None:
            octo.close()
        stop_board(proc)
    pins = json.loads(report.read_text())
    assert pins["position_steps"][:3] == twin_end_steps(cut, tmp_path)[:3], pins
    assert pins["net_steps"][3] > 0, pins
