"""`gweave serve` driven by a real OctoPrint, as a user drives it: through OctoPrint's REST API.

OctoPrint (requirements-octoprint.txt, the version issue #20 was reported against) runs as a
subprocess on 127.0.0.1 with its own temporary base folder: a config with a preset API key, the
virtual printer's pty among its serial ports, short communication timeouts (so that "idle for
longer than three timeouts" takes seconds) and the plugins that would go online disabled. It is
started with `--iknowwhatimdoing`, the flag that lets it run as root (CI containers). The
machine's own serial ports are blacklisted so that `AUTO` finds the virtual printer.

One test walks through a session in order (each step needs the one before): connect to the
explicit port; stay Operational through an idle period with live temperatures; heat to a target
set while idle; print a real fixture to 100 % and stay connected; upload to the SD card and print
from it; pause (in about a second), resume and cancel; an M600 filament change answered through
OctoPrint's prompt dialog; disconnect and reconnect with the port found by `AUTO`. OctoPrint's
serial log must never say "Unknown command". Both processes are always stopped.
"""

import os
import secrets
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("octoprint", reason="pip install -r crates/gweave-py/requirements-octoprint.txt")
requests = pytest.importorskip("requests")

FIXTURE = ("prusaslicer", "pr_torus_pva.gcode")
# OctoPrint's communication timeout in this test, s: it gives up after three in a row.
COMM_TIMEOUT_S = 4.0


def gweave_command() -> list:
    """The CLI under test: $GWEAVE if set (a built binary), else the installed Python package."""
    exe = os.environ.get("GWEAVE")
    return [exe] if exe else [sys.executable, "-m", "gweave"]


def wait_for(condition, timeout_s: float, what: str):
    deadline = time.monotonic() + timeout_s
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")
        time.sleep(0.05)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=10)


class OctoPrint:
    """A real OctoPrint server with a temporary base folder, and its REST API."""

    def __init__(self, tmp: Path, port_path: Path):
        self.base = tmp / "octoprint"
        self.base.mkdir()
        self.key = secrets.token_hex(16).upper()
        (self.base / "config.yaml").write_text(
            "\n".join(
                [
                    "server:",
                    "  firstRun: false",
                    "  onlineCheck: {enabled: false}",
                    "  pluginBlacklist: {enabled: false}",
                    "api:",
                    f"  key: {self.key}",
                    "serial:",
                    f"  additionalPorts: ['{port_path}']",
                    # AUTO must find the virtual printer, not a real serial port of the machine.
                    "  blacklistedPorts: ['/dev/tty*']",
                    "  log: true",
                    f"  timeout: {{communication: {COMM_TIMEOUT_S}, communicationBusy: 2.0, connection: 10.0}}",
                    "plugins:",
                    "  _disabled: [announcements, tracking, softwareupdate, pluginmanager, pi_support,",
                    "    achievements, health_check, backup, firmware_check, discovery]",
                    "",
                ]
            )
        )
        self.url = f"http://127.0.0.1:{free_port()}"
        port = self.url.rsplit(":", 1)[1]
        args = ["serve", "--iknowwhatimdoing", "--basedir", str(self.base), "--host", "127.0.0.1", "--port", port]
        self.out = open(tmp / "octoprint.out", "w")
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "octoprint"] + args, stdout=self.out, stderr=subprocess.STDOUT
        )
        wait_for(self.up, 90, "OctoPrint to listen")

    def up(self) -> bool:
        assert self.proc.poll() is None, "OctoPrint exited, see octoprint.out"
        try:
            return requests.get(self.url + "/api/version", headers=self.headers(), timeout=2).ok
        except requests.ConnectionError:
            return False

    def headers(self) -> dict:
        return {"X-Api-Key": self.key}

    def get(self, path: str) -> dict:
        r = requests.get(self.url + path, headers=self.headers(), timeout=10)
        r.raise_for_status()
        return r.json()

    def post(self, path: str, body: dict) -> None:
        r = requests.post(self.url + path, json=body, headers=self.headers(), timeout=10)
        assert r.ok, f"POST {path} {body}: {r.status_code} {r.text}"

    def upload(self, target: str, path: Path, **fields) -> None:
        with open(path, "rb") as f:
            r = requests.post(
                f"{self.url}/api/files/{target}", files={"file": (path.name, f)}, data=fields,
                headers=self.headers(), timeout=60,
            )
        assert r.ok, r.text

    def state(self) -> str:
        return self.get("/api/connection")["current"]["state"]

    def job(self) -> dict:
        return self.get("/api/job")

    def serial_log(self) -> str:
        path = self.base / "logs" / "serial.log"
        return path.read_text(errors="replace") if path.exists() else ""

    def close(self) -> None:
        stop(self.proc)
        self.out.close()


@pytest.fixture
def session(tmp_path):
    """`gweave serve --pty` and OctoPrint, both stopped whatever happens."""
    link = tmp_path / "gweave0"
    sd = tmp_path / "sd"
    sd.mkdir()
    args = ["serve", "--pty", str(link), "--sd", str(sd), "--log", str(tmp_path / "serve.log")]
    # The idle limit ends a server the test forgot.
    serve_err = open(tmp_path / "serve.err", "w")
    serve = subprocess.Popen(gweave_command() + args + ["--exit-after-idle", "300"], stderr=serve_err)
    octo = None
    try:
        wait_for(lambda: link.is_symlink() or serve.poll() is not None, 30, "the pty link")
        assert serve.poll() is None, (tmp_path / "serve.err").read_text()
        octo = OctoPrint(tmp_path, link)
        yield octo, link, sd
    finally:
        if octo is not None:
            octo.close()
        stop(serve)
        serve_err.close()


def connect(octo: OctoPrint, port: str) -> None:
    """Connects to `port` (a path, or `AUTO`: OctoPrint tries every port it lists)."""
    octo.post("/api/connection", {"command": "connect", "port": port, "baudrate": 115200})
    wait_for(lambda: octo.state() == "Operational", 30, "Operational after connecting")


def test_octoprint_keeps_the_virtual_printer_and_prints_from_both_storages(session, data, tmp_path):
    octo, link, sd = session
    connect(octo, str(link))
    # OctoPrint is "Operational" before it has read the card's answer to its M21 (a loaded
    # machine shows the gap): the card must be ready soon after, as the first temperature.
    wait_for(lambda: octo.get("/api/printer")["sd"]["ready"], 10, "the SD card ready after M21")
    wait_for(lambda: "tool0" in octo.get("/api/printer")["temperature"], 10, "the first temperature report")

    # Idle for longer than three communication timeouts, with a target set meanwhile: the board
    # must auto-report (M155) and heat in wall time, and OctoPrint must never give up.
    octo.post("/api/printer/tool", {"command": "target", "targets": {"tool0": 60}})
    started = time.monotonic()
    readings = []
    while time.monotonic() - started < 3.5 * COMM_TIMEOUT_S:
        assert octo.state() == "Operational", octo.serial_log()[-3000:]
        tool = octo.get("/api/printer")["temperature"]["tool0"]
        readings.append(tool["actual"])
        time.sleep(1.0)
    assert readings[-1] > readings[0] + 5, f"the hotend did not heat while idle: {readings}"
    wait_for(lambda: octo.get("/api/printer")["temperature"]["tool0"]["actual"] >= 58, 60, "60 C")

    # A real fixture, streamed by OctoPrint, to 100 %; still connected well after the end.
    fixture = data.joinpath(*FIXTURE)
    octo.upload("local", fixture, select="true", print="true")
    wait_for(lambda: octo.job()["state"].startswith("Printing"), 30, "the print to start")
    wait_for(lambda: octo.job()["state"] == "Operational", 180, "the print to end")
    assert octo.job()["progress"]["completion"] == 100.0
    time.sleep(3 * 2.0 + 1)  # three busy-protocol timeouts (communicationBusy)
    assert octo.state() == "Operational"

    # Upload to the SD card through the protocol (M28/M29), then print it from the card.
    small = tmp_path / "small.gcode"
    small.write_bytes(fixture.read_bytes()[:150_000].rsplit(b"\n", 1)[0] + b"\n")
    octo.upload("sdcard", small)
    sd_name = wait_for(
        lambda: next((f["name"] for f in octo.get("/api/files/sdcard")["files"]), None), 60, "the SD upload"
    )
    wait_for(lambda: octo.state() == "Operational", 60, "the SD upload to finish")
    assert (sd / "SMALL.GCO").read_bytes().count(b"\n") > 1000
    octo.post(f"/api/files/sdcard/{sd_name}", {"command": "select", "print": True})
    wait_for(lambda: "Done printing file" in octo.serial_log(), 120, "the SD print to end")
    wait_for(lambda: octo.state() == "Operational", 30, "Operational after the SD print")

    # Pause, resume and cancel a print from OctoPrint's storage; a pause takes about a second.
    octo.post("/api/files/local/" + fixture.name, {"command": "select", "print": True})
    # Past the start G-code: its intro line is seconds of slow moves, which a pause (M400) waits
    # for on a real board too.
    wait_for(lambda: (octo.job()["progress"]["completion"] or 0) > 10, 30, "the second print under way")
    for _ in range(2):
        asked = time.monotonic()
        octo.post("/api/job", {"command": "pause", "action": "pause"})
        wait_for(lambda: octo.job()["state"] == "Paused", 10, "Paused")
        assert time.monotonic() - asked < 2.5, f"pause took {time.monotonic() - asked:.2f} s"
        octo.post("/api/job", {"command": "pause", "action": "resume"})
        wait_for(lambda: octo.job()["state"] == "Printing", 10, "Printing again")
    octo.post("/api/job", {"command": "cancel"})
    wait_for(lambda: octo.job()["state"] == "Operational", 20, "Operational after cancelling")

    # M600 from the terminal: OctoPrint shows Marlin's prompt; answering it resumes the board.
    octo.post("/api/printer/command", {"commands": ["G28", "M600"]})
    # The plugin answers nothing (JSON null) while no prompt is open; M600 opens "Pause" first.
    def prompt() -> dict:
        return octo.get("/api/plugin/action_command_prompt") or {}

    wait_for(lambda: prompt().get("text") == "Nozzle Parked", 60, "the Nozzle Parked prompt")
    assert prompt()["choices"] == ["Continue"]
    time.sleep(2 * COMM_TIMEOUT_S)  # paused for the user, and still connected
    assert octo.state() == "Operational"
    octo.post("/api/plugin/action_command_prompt", {"command": "select", "choice": 0})
    wait_for(lambda: "//action:prompt_begin Paused" in octo.serial_log(), 30, "the purge prompt")
    octo.post("/api/printer/command", {"commands": ["M400"]})
    wait_for(lambda: octo.serial_log().rstrip().endswith("Recv: ok"), 30, "the board to answer again")

    # Disconnect and reconnect, this time letting OctoPrint find the port: a fresh power-on.
    octo.post("/api/connection", {"command": "disconnect"})
    wait_for(lambda: octo.state() == "Closed", 20, "Closed")
    connect(octo, "AUTO")

    log = octo.serial_log()
    assert "Unknown command" not in log, [l for l in log.splitlines() if "Unknown command" in l][:10]
    assert "consecutive communication timeouts" not in log
    assert log.count("Recv: start") == 2
