"""A headless Chromium driven over the DevTools protocol on a pipe (``--remote-debugging-pipe``:
the browser reads commands on fd 3 and writes replies on fd 4, each a JSON text ended by a NUL),
so tests can run script in a page in real time (frame rates), resize the window and take
screenshots without any package beyond the standard library.
"""

import base64
import fcntl
import json
import os
import shutil
import subprocess
import time
from pathlib import Path
from typing import Any, Dict, Optional

import pytest

# Flags that keep a headless browser off the network and away from the user's profile.
FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--hide-scrollbars",
    "--force-device-scale-factor=1",
]


def chromium() -> str:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    why = "no chromium on PATH; run `make browser-deps` as root (apt-get install chromium)"
    print(why)
    pytest.skip(why)


class Browser:
    """One browser with one page; ``open`` loads a file and waits for the viewer to be ready."""

    def __init__(self, tmp: Path, width: int = 1400, height: int = 900):
        to_browser_r, self._to_browser = os.pipe()
        self._from_browser, from_browser_w = os.pipe()

        def fds() -> None:
            # Out of the way first: either pipe end may itself be fd 3 or 4.
            r, w = (fcntl.fcntl(fd, fcntl.F_DUPFD, 10) for fd in (to_browser_r, from_browser_w))
            for fd, target in ((r, 3), (w, 4)):
                os.dup2(fd, target)
                os.set_inheritable(target, True)

        cmd = [chromium(), *FLAGS, "--remote-debugging-pipe", f"--user-data-dir={tmp / 'profile'}"]
        cmd += [f"--window-size={width},{height}", "about:blank"]
        self.proc = subprocess.Popen(
            cmd, preexec_fn=fds, close_fds=False, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
        )
        os.close(to_browser_r)
        os.close(from_browser_w)
        self._id, self._buf, self.session = 0, b"", None
        page = next(t for t in self.send("Target.getTargets")["targetInfos"] if t["type"] == "page")
        self.session = self.send("Target.attachToTarget", targetId=page["targetId"], flatten=True)["sessionId"]
        self.resize(width, height)

    def send(self, method: str, **params: Any) -> Dict[str, Any]:
        self._id += 1
        msg: Dict[str, Any] = {"id": self._id, "method": method, "params": params}
        if self.session and not method.startswith("Target."):
            msg["sessionId"] = self.session
        os.write(self._to_browser, json.dumps(msg).encode() + b"\0")
        while True:
            while b"\0" not in self._buf:
                chunk = os.read(self._from_browser, 1 << 20)
                assert chunk, "the browser closed the pipe"
                self._buf += chunk
            text, self._buf = self._buf.split(b"\0", 1)
            reply = json.loads(text)
            if reply.get("id") == self._id:
                assert "error" not in reply, reply["error"]
                return reply["result"]

    def resize(self, width: int, height: int) -> None:
        self.send("Emulation.setDeviceMetricsOverride", width=width, height=height, deviceScaleFactor=1, mobile=False)

    def eval(self, expression: str) -> Any:
        r = self.send("Runtime.evaluate", expression=expression, awaitPromise=True, returnByValue=True)
        assert "exceptionDetails" not in r, r["exceptionDetails"]
        return r["result"].get("value")

    def open(self, page: Path, fragment: str = "", timeout_s: float = 60) -> None:
        self.send("Page.navigate", url=page.as_uri() + (f"#{fragment}" if fragment else ""))
        end = time.monotonic() + timeout_s
        while self.eval("document.body && document.body.dataset.ready || null") != "1":
            error = self.eval("window.__error || null")
            assert error is None, error
            assert time.monotonic() < end, "the viewer did not get ready"
            time.sleep(0.05)
        self.settle()

    def settle(self) -> None:
        """Waits until the camera rests and the full set is drawn (two frames)."""
        self.eval("new Promise(r => setTimeout(() => requestAnimationFrame(() => requestAnimationFrame(r)), 200))")

    def screenshot(self, path: Optional[Path] = None):
        """The page as a NumPy array (height, width, 3) of 8-bit RGB."""
        import numpy as np
        from PIL import Image
        import io

        png = base64.b64decode(self.send("Page.captureScreenshot", format="png")["data"])
        if path is not None:
            path.write_bytes(png)
        return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))

    def close(self) -> None:
        try:
            self.send("Browser.close")
        except (AssertionError, OSError):
            pass
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
        os.close(self._to_browser)
        os.close(self._from_browser)
