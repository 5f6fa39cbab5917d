"""The OctoPrint plugin (integrations/octoprint) in a real OctoPrint.

The plugin is pip-installed into this environment (where ``make py-deps`` put OctoPrint), then an
OctoPrint server runs on 127.0.0.1 with a temporary base folder: an admin user with an API key,
no first-run wizard, no network checks. Files go in through the REST API as a user's browser
sends them; what OctoPrint answers and what it stored are compared with gweave's own results.
The server is always stopped.
"""

import json
import os
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

import gweave

ROOT = Path(__file__).resolve().parents[3]
PLUGIN = ROOT / "integrations" / "octoprint"
BIN = Path(sys.executable).parent
KEY = "GWEAVETESTKEY0123456789ABCDEF012"
USER = "gweave"
# Longest wait for the server to answer, and for an analysis, seconds.
START_S, ANALYSIS_S = 90, 60

requests = pytest.importorskip("requests", reason="OctoPrint is not installed: run `make py-deps`")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def config(port: int) -> str:
    plugins_off = ["announcements", "tracking", "softwareupdate", "pluginmanager", "discovery", "errortracking",
                   "firmware_check", "file_check", "achievements", "backup", "health_check", "pi_support"]
    return json.dumps({
        "server": {"firstRun": False, "onlineCheck": {"enabled": False}, "pluginBlacklist": {"enabled": False},
                   "host": "127.0.0.1", "port": port},
        "accessControl": {"autologinLocal": True, "autologinAs": USER, "localNetworks": ["127.0.0.0/8"],
                          "autologinHeadsupAcknowledged": True},
        # OctoPrint's own virtual printer, for a connected printer (selecting a file needs one).
        "plugins": {"_disabled": plugins_off, "virtual_printer": {"enabled": True}},
        # Nothing to connect to: a short serial timeout keeps a stray connection attempt short.
        "serial": {"autoconnect": False, "timeout": {"connection": 2, "detection": 1}},
        "gcodeAnalysis": {"runAt": "always"},
    })


class OctoPrint:
    def __init__(self, url: str, base: Path) -> None:
        self.url, self.base = url, base
        self.http = requests.Session()
        self.http.headers["X-Api-Key"] = KEY

    def upload(self, path: Path, name: str) -> requests.Response:
        with open(path, "rb") as f:
            return self.http.post(f"{self.url}/api/files/local", files={"file": (name, f, "application/octet-stream")})

    def settings(self, **gweave_settings) -> None:
        r = self.http.post(f"{self.url}/api/settings", json={"plugins": {"gweave": gweave_settings}})
        assert r.ok, r.text

    def file(self, name: str, until=lambda f: True) -> dict:
        deadline = time.monotonic() + ANALYSIS_S
        while True:
            r = self.http.get(f"{self.url}/api/files/local/{name}")
            if r.ok and until(r.json()):
                return r.json()
            assert time.monotonic() < deadline, f"{name}: {r.status_code} {r.text[:2000]}"
            time.sleep(0.3)

    def connect(self) -> None:
        r = self.http.post(f"{self.url}/api/connection", json={"command": "connect", "port": "VIRTUAL"})
        assert r.status_code == 204, r.text
        deadline = time.monotonic() + 30
        while self.http.get(f"{self.url}/api/connection").json()["current"]["state"] != "Operational":
            assert time.monotonic() < deadline, self.http.get(f"{self.url}/api/connection").text
            time.sleep(0.3)

    def stored(self, name: str) -> bytes:
        return (self.base / "uploads" / name).read_bytes()


@pytest.fixture(scope="module")
def plugin():
    """The plugin pip-installed here, as a user installs it into OctoPrint's environment."""
    assert (BIN / "octoprint").exists(), "OctoPrint is not in this environment: run `make py-deps`"
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-warn-conflicts", str(PLUGIN)], check=True)


@pytest.fixture(scope="module")
def octoprint(plugin, tmp_path_factory):
    octoprint_bin = BIN / "octoprint"
    base = tmp_path_factory.mktemp("octoprint")
    port = free_port()
    (base / "config.yaml").write_text(config(port))  # JSON is YAML
    subprocess.run([str(octoprint_bin), "--basedir", str(base), "user", "add", USER, "--password", USER, "--admin"],
                   check=True, capture_output=True, timeout=120)
    users = base / "users.yaml"
    import yaml  # OctoPrint's dependency

    data = yaml.safe_load(users.read_text())
    data[USER]["apikey"] = KEY
    users.write_text(yaml.safe_dump(data))
    # OctoPrint refuses to run as root unless told it may (CI containers run as root).
    root = ["--iknowwhatimdoing"] if os.geteuid() == 0 else []
    log = open(base / "serve.log", "wb")
    server = subprocess.Popen([str(octoprint_bin), "serve", "--basedir", str(base), *root],
                              stdout=log, stderr=subprocess.STDOUT)
    client = OctoPrint(f"http://127.0.0.1:{port}", base)
    try:
        deadline = time.monotonic() + START_S
        while True:
            assert server.poll() is None, (base / "serve.log").read_text()[-3000:]
            try:
                if client.http.get(f"{client.url}/api/version", timeout=2).ok:
                    break
            except requests.ConnectionError:
                pass
            assert time.monotonic() < deadline, (base / "serve.log").read_text()[-3000:]
            time.sleep(0.5)
        r = client.http.get(f"{client.url}/api/plugin/gweave")
        assert r.ok, ("the gweave plugin did not load", r.status_code, (base / "logs" / "octoprint.log").read_text()[-3000:])
        yield client
    finally:
        server.terminate()
        try:
            server.wait(timeout=20)
        except subprocess.TimeoutExpired:
            server.kill()
            server.wait()
        log.close()


# Runs the plugin's analysis in a fresh process: its progress, and the largest memory any gweave
# run it started took (resource.RUSAGE_CHILDREN of that process alone).
ANALYSE = """
import json, resource, sys
from octoprint_gweave import analysis, runner
# Sampled every 20 ms rather than 250: `stats` reads the 12 MB file in less than one default
# period since the lexer got faster, and this test asks for samples within that step.
runner.POLL_S = 0.02
seen = []
r = analysis.analyse(sys.argv[1], machine=None, bed=(200, 200, 200), timeout_s=600, progress=seen.append)
print(json.dumps({"progress": seen, "peak_mb": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024,
                  "time": r["estimatedPrintTime"]}))
"""


def test_octoprint_analysis_reports_progress_in_bounded_memory(plugin, data, tmp_path):
    dual = (data / "cura" / "cura_dual.gcode").read_bytes()
    runs = {}
    for copies in (1, 4):
        big = tmp_path / f"x{copies}.gcode"
        big.write_bytes(dual * copies)
        out = subprocess.run([sys.executable, "-c", ANALYSE, str(big)], capture_output=True, text=True, check=True)
        runs[copies] = json.loads(out.stdout)
    progress = runs[4]["progress"]
    # Read positions sampled while gweave reads: many steps, never backwards, ending at 1.
    assert len(set(progress)) >= 8, progress
    assert progress == sorted(progress) and progress[-1] == 1.0, progress
    assert any(0 < p < 0.15 for p in progress), "progress within the first step (stats), not only between steps"
    # Four times the file, the same memory (to within the noise of a process start).
    assert runs[4]["peak_mb"] < runs[1]["peak_mb"] + 10, runs
    assert runs[4]["time"] > 3.9 * runs[1]["time"]


# A child reading a file as gweave does: its two ends first (the settings, a cut file's footer:
# the last 256 KB), closed, then the whole file forward in steps.
ENDS_THEN_READ = """
import os, sys, time
path = sys.argv[1]
with open(path, "rb") as f:
    f.read(64 * 1024)
    f.seek(-256 * 1024, os.SEEK_END)
    f.read()
    time.sleep(0.15)  # several sample periods positioned at the tail
with open(path, "rb") as f:
    while f.read(64 * 1024):
        time.sleep(0.01)
"""


# The plugin's watcher on that child, sampling every 20 ms; prints what it reported.
WATCH = """
import json, subprocess, sys, threading
from octoprint_gweave import runner
runner.POLL_S = 0.02
seen, stop = [], threading.Event()
child = subprocess.Popen([sys.executable, "-c", sys.argv[1], sys.argv[2]])
watcher = threading.Thread(target=runner._watch, args=(child.pid, sys.argv[2], seen.append, stop))
watcher.start()
child.wait(timeout=60)
stop.set()
watcher.join()
print(json.dumps(seen))
"""


def test_octoprint_progress_never_goes_back_when_gweave_reads_the_tail_first(plugin, tmp_path):
    big = tmp_path / "big.gcode"
    big.write_bytes(b"G1 X1 Y1 E0.1\n" * 200_000)  # 2.8 MB: 44 reads, ~0.5 s
    out = subprocess.run([sys.executable, "-c", WATCH, ENDS_THEN_READ, str(big)], capture_output=True, text=True,
                         check=True)
    seen = json.loads(out.stdout)
    assert seen == sorted(seen), seen
    # The main read's progress, not the tail's position: the first figure is early in the file.
    assert seen and seen[0] < 0.5 and len(seen) >= 5, seen


# A checksum error on line 2 (gweave check: an error; gweave stats refuses the file).
BAD = b"M104 S200\nN1 G1 X10 Y10*99\nG1 X20 E1\n"


def analysed(f: dict) -> bool:
    return "gweave" in (f.get("gcodeAnalysis") or {})


def test_octoprint_shows_gweave_time_and_filament(octoprint, data):
    fixture = data / "cura" / "cura_torus.gcode"
    assert octoprint.upload(fixture, "torus.gcode").status_code == 201
    a = octoprint.file("torus.gcode", analysed)["gcodeAnalysis"]
    est = gweave.estimate(fixture)
    stats = gweave.stats(fixture)
    assert round(a["estimatedPrintTime"]) == round(est["total_s"]), (a["estimatedPrintTime"], est["total_s"])
    assert a["estimatedPrintTime"] == est["total_s"]
    assert a["filament"] == {
        f"tool{t['tool']}": {"length": t["extruded_mm"], "volume": t["extruded_mm3"] / 1000} for t in stats["filament"]
    }
    assert a["layers"] == stats["layers"] == 28
    lo, hi = stats["extrusion_bounds"]["min"], stats["extrusion_bounds"]["max"]
    assert (a["printingArea"]["minX"], a["printingArea"]["maxZ"]) == (lo[0], hi[2])
    assert a["dimensions"]["height"] == pytest.approx(hi[2] - lo[2])
    assert a["gweave"]["errors"] == [] and a["gweave"]["planner"] == "marlin"


def test_octoprint_times_with_the_machine_profile_set(octoprint, data):
    fixture = data / "cura" / "cura_torus.gcode"
    klipper = ROOT / "examples" / "machines" / "klipper.toml"
    octoprint.settings(machine=str(klipper))
    try:
        assert octoprint.upload(fixture, "torus_klipper.gcode").status_code == 201
        a = octoprint.file("torus_klipper.gcode", analysed)["gcodeAnalysis"]
    finally:
        octoprint.settings(machine="")
    est = gweave.estimate(fixture, machine=klipper)
    assert a["estimatedPrintTime"] == est["total_s"] != gweave.estimate(fixture)["total_s"]
    assert a["gweave"]["planner"] == "klipper" and a["gweave"]["machine_path"] == str(klipper)


def test_octoprint_upload_is_purge_shifted_like_the_cli(octoprint, data, tmp_path):
    fixture = data / "slic3r" / "slic3r_cone_2tool.gcode"
    octoprint.settings(on_upload="purge-shift --purge-mm 2.5")
    try:
        assert octoprint.upload(fixture, "cone.gcode").status_code == 201
        f = octoprint.file("cone.gcode", lambda f: "gweave" in f and analysed(f))
    finally:
        octoprint.settings(on_upload="")
    expected = tmp_path / "cone.gcode"
    gweave.purge_shift(fixture, expected, purge_mm=2.5)
    stored = octoprint.stored("cone.gcode")
    assert stored != fixture.read_bytes()
    assert stored == expected.read_bytes()
    assert f["gweave"]["upload"]["ok"] is True and f["gweave"]["upload"]["error"] is None
    # The analysis is of the stored file: two tools.
    assert set(f["gcodeAnalysis"]["filament"]) == {"tool0", "tool1"}


def test_octoprint_refused_upload_is_kept_and_says_why(octoprint, data):
    fixture = data / "slic3r" / "slic3r_cone_2tool.gcode"
    octoprint.settings(on_upload="purge-shift --purge-mm=-1")
    try:
        assert octoprint.upload(fixture, "refused.gcode").status_code == 201
        f = octoprint.file("refused.gcode", lambda f: "gweave" in f)
    finally:
        octoprint.settings(on_upload="")
    assert octoprint.stored("refused.gcode") == fixture.read_bytes()
    upload = f["gweave"]["upload"]
    assert upload["ok"] is False
    assert "invalid value '-1' for '--purge-mm <MM>': out of range: 0 to 1000 mm" in upload["error"], upload
    recent = octoprint.http.get(f"{octoprint.url}/api/plugin/gweave").json()["uploads"]
    assert any(u["path"] == "refused.gcode" and not u["ok"] for u in recent)
    log = (octoprint.base / "logs" / "octoprint.log").read_text()
    assert "refused.gcode stored as uploaded: error: invalid value '-1' for '--purge-mm <MM>'" in log


def test_octoprint_refuses_to_print_a_file_with_errors(octoprint, tmp_path):
    bad = tmp_path / "bad.gcode"
    bad.write_bytes(BAD)
    assert octoprint.upload(bad, "bad.gcode").status_code == 201
    a = octoprint.file("bad.gcode", analysed)["gcodeAnalysis"]["gweave"]
    # `gweave stats` refuses the file (no time or filament then), `gweave check` finds the error.
    assert a["check"]["errors"] == 1 and a["errors"][1:] == ["gweave check: 1 error"], a
    assert a["errors"][0].startswith("gweave stats: gweave: error: ") and "bad.gcode:2:14: checksum mismatch" in a["errors"][0]
    assert a["check"]["first"][0] == {
        "line": 2, "column": 14, "severity": "error", "message": "checksum mismatch: line says 99, bytes give 40"}
    octoprint.settings(block_on_errors=True)
    try:
        r = octoprint.http.post(f"{octoprint.url}/api/files/local/bad.gcode", json={"command": "select", "print": True})
    finally:
        octoprint.settings(block_on_errors=False)
    assert r.status_code == 409, r.text
    assert "bad.gcode not printed: gweave stats: " in r.json()["error"]
    assert r.json()["error"].endswith("; gweave check: 1 error"), r.json()


def chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    pytest.skip("no chromium on PATH; run `make browser-deps` as root (apt-get install chromium)")


class Browser:
    """Headless Chromium driven over its DevTools protocol: the page runs in real time, OctoPrint's
    socket and all (``--screenshot`` with a virtual time budget never ends on a page that keeps
    a socket open)."""

    def __init__(self, tmp: Path) -> None:
        import websocket  # websocket-client, OctoPrint's dependency

        from _cdp import FLAGS

        profile = tmp / "profile"
        self.proc = subprocess.Popen(
            [chromium(), *FLAGS, f"--user-data-dir={profile}", "--window-size=1280,1200",
             "--remote-debugging-port=0", "about:blank"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        port_file = profile / "DevToolsActivePort"
        deadline = time.monotonic() + 30
        while not port_file.exists() or not port_file.read_text().strip():
            assert time.monotonic() < deadline and self.proc.poll() is None, "chromium did not start"
            time.sleep(0.1)
        port = int(port_file.read_text().split()[0])
        page = next(p for p in requests.get(f"http://127.0.0.1:{port}/json/list").json() if p["type"] == "page")
        self.ws = websocket.create_connection(page["webSocketDebuggerUrl"], timeout=60, suppress_origin=True)
        self.n = 0

    def call(self, method: str, **params):
        self.n += 1
        self.ws.send(json.dumps({"id": self.n, "method": method, "params": params}))
        while True:
            msg = json.loads(self.ws.recv())
            if msg.get("id") == self.n:
                assert "error" not in msg, msg
                return msg["result"]

    def js(self, expression: str):
        return self.call("Runtime.evaluate", expression=expression, returnByValue=True)["result"].get("value")

    def wait(self, expression: str, timeout_s: float = 60):
        """Evaluates `expression` in the page every half second until it is truthy; its value."""
        deadline = time.monotonic() + timeout_s
        while not (value := self.js(expression)):
            assert time.monotonic() < deadline, f"never true in the page: {expression}"
            time.sleep(0.5)
        return value

    def screenshot(self, path: Path) -> None:
        import base64

        path.write_bytes(base64.b64decode(self.call("Page.captureScreenshot", format="png")["data"]))

    def close(self) -> None:
        self.ws.close()
        self.proc.terminate()
        self.proc.wait(timeout=20)


def test_octoprint_page_shows_the_badge_and_settings(octoprint, data, tmp_path):
    """OctoPrint's page in headless Chromium: the badges in the file list, the settings page.

    ``GWEAVE_SCREENSHOTS=docs/images`` also keeps the screenshots there (for the docs).
    """
    chromium()
    # Files with each kind of badge: analysed, purge-shifted on upload, refused by the check.
    bad = tmp_path / "bad.gcode"
    bad.write_bytes(BAD)
    for path, name in ((data / "cura" / "cura_torus.gcode", "torus.gcode"), (bad, "bad.gcode")):
        assert octoprint.upload(path, name).status_code == 201
        octoprint.file(name, analysed)
    octoprint.settings(on_upload="purge-shift --purge-mm 2.5")
    try:
        octoprint.upload(data / "slic3r" / "slic3r_cone_2tool.gcode", "cone.gcode")
        octoprint.file("cone.gcode", lambda f: "gweave" in f and analysed(f))
    finally:
        octoprint.settings(on_upload="")
    browser = Browser(tmp_path)
    try:
        browser.call("Page.navigate", url=octoprint.url)
        # Badges settle once no analysis is running (OctoPrint may analyse a file again, and
        # its progress label shows until that ends). They are read in the same evaluation as
        # the condition: read apart, an analysis that began in between once showed its
        # progress label in the torus' badge (`gweave 15 % gweave 00:12:02`).
        badges = browser.wait(
            "document.querySelectorAll('.gweave-badge .label').length >= 4"
            " && document.querySelectorAll('.gweave-badge .label-info').length == 0"
            " && Array.from(document.querySelectorAll('.gweave-badge')).map(e => e.innerText.trim())"
        )
        t = int(gweave.estimate(data / "cura" / "cura_torus.gcode")["total_s"])  # OctoPrint floors
        torus = f"gweave {t // 3600:02}:{t // 60 % 60:02}:{t % 60:02}"
        assert any(b.startswith(torus) for b in badges), (torus, badges)
        assert any("gweave purge-shift" in b for b in badges), badges
        assert any(b.startswith("gweave 00:00:00, 2 errors") for b in badges), badges  # bad.gcode
        # The check of a selected file, as a notification on the page.
        octoprint.connect()
        r = octoprint.http.post(f"{octoprint.url}/api/files/local/bad.gcode", json={"command": "select"})
        assert r.status_code == 204, r.text
        browser.wait("$('.ui-pnotify:contains(\"gweave: bad.gcode\")').length > 0")
        note = browser.js("$('.ui-pnotify:contains(\"gweave: bad.gcode\")').text()")
        assert "gweave check: 1 error" in note and "checksum mismatch" in note, note
        time.sleep(1)  # the notification's fade-in
        shots = [tmp_path / "octoprint.png", tmp_path / "octoprint_settings.png"]
        browser.screenshot(shots[0])
        browser.js("PNotify.removeAll(), true")
        browser.js("$('#navbar_show_settings').click(), true")
        browser.wait("$('#settings_plugin_gweave_link a').length > 0")
        browser.js("$('#settings_plugin_gweave_link a').click(), true")
        browser.wait("$('#gweave_on_upload').is(':visible')")
        time.sleep(1)  # the dialog's fade-in
        browser.screenshot(shots[1])
    finally:
        browser.close()
    for shot in shots:
        assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and shot.stat().st_size > 30_000
    keep = os.environ.get("GWEAVE_SCREENSHOTS")
    if keep:
        for shot in shots:
            shutil.copy(shot, ROOT / keep / shot.name)
