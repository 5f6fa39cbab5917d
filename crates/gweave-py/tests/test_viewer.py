"""The HTML viewer in a real headless browser (Debian ``chromium``, installed by ``make browser-deps``).

The page reads its state from the URL fragment (``#layer=N``) through the same code the layer
slider runs, so two screenshots at two layers show what moving the slider does. The test asserts
that the drawing changed and that both tools' colours are on the screen.
"""

import os
import shutil
import subprocess
from pathlib import Path

import pytest

import gweave
from _png import read_png

ORANGE, BLUE = (0xE6, 0x9F, 0x00), (0x00, 0x72, 0xB2)
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


def run(browser: str, tmp: Path, url: str, *args: str) -> subprocess.CompletedProcess:
    cmd = [browser, *FLAGS, f"--user-data-dir={tmp / 'profile'}", "--window-size=1000,700", *args, url]
    return subprocess.run(cmd, capture_output=True, timeout=120, cwd=tmp)


def near(p, c, tol=6):
    return all(abs(a - b) <= tol for a, b in zip(p, c))


def shot(browser: str, tmp: Path, page: Path, fragment: str):
    out = tmp / f"{fragment.replace('=', '_').replace('&', '_')}.png"
    r = run(browser, tmp, f"{page.as_uri()}#{fragment}", f"--screenshot={out}", "--virtual-time-budget=5000")
    assert out.exists(), r.stderr.decode(errors="replace")[-2000:]
    return read_png(out.read_bytes())


def test_viewer_draws_and_follows_the_layer_slider(data, tmp_path):
    browser = chromium()
    page = tmp_path / "dual.html"
    gweave.preview(data / "cura" / "cura_dual.gcode", output=page)

    # The script ran without error: it marks the layer and the paths it drew on <body>.
    r = run(browser, tmp_path, f"{page.as_uri()}#layer=60", "--dump-dom", "--virtual-time-budget=5000")
    dom = r.stdout.decode(errors="replace")
    assert 'data-layer="60"' in dom and 'data-paths="2"' in dom, dom[-1500:]
    assert "cura" in dom and "T1 filament" in dom, "stats table filled in"

    w, h, low = shot(browser, tmp_path, page, "layer=60")
    _, _, high = shot(browser, tmp_path, page, "layer=150")
    assert (w, h) == (1000, 700)
    # Both tools print at layer 60; at layer 150 only the sphere (T1) is left above the cylinder.
    assert sum(near(p, ORANGE) for p in low) > 2000
    assert sum(near(p, BLUE) for p in low) > 2000
    assert sum(near(p, BLUE) for p in high) > 2000
    changed = sum(a != b for a, b in zip(low, high))
    assert changed > 20_000, changed


def test_viewer_iso_view_and_feature_colours(data, tmp_path):
    browser = chromium()
    page = tmp_path / "bunny.html"
    gweave.preview(data / "prusaslicer" / "pr_bunny_3tool_rel.gcode", output=page, colour_by="feature")
    _, _, px = shot(browser, tmp_path, page, "view=iso&colour=feature")
    outer_wall = (0xFF, 0x7D, 0x38)
    assert sum(near(p, outer_wall, 10) for p in px) > 3000
