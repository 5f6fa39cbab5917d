"""The PrusaSlicer post-processing line of docs/integrations.md, run by PrusaSlicer itself.

PrusaSlicer's command line runs the print's post-processing scripts when it exports G-code, as
its GUI does. A first script keeps a copy of the file as PrusaSlicer hands it over; the second is
the documented gweave line. The result must equal the CLI's on that copy. Skipped without
``prusa-slicer`` (Debian's package; ``make bench`` installs it as root).
"""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
GWEAVE = Path(sys.executable).parent / "gweave"
MODEL = Path("/usr/share/PrusaSlicer/shapes/M3_hex_nut.stl")


def test_prusaslicer_post_processing_line_equals_the_cli(tmp_path):
    slicer = shutil.which("prusa-slicer")
    if slicer is None or not MODEL.exists():
        pytest.skip("no prusa-slicer (apt-get install prusa-slicer)")
    profile = ROOT / "examples" / "mix" / "seed_layers.toml"
    before, out, cli = tmp_path / "before.gcode", tmp_path / "out.gcode", tmp_path / "cli.gcode"
    # One script per line; PrusaSlicer appends the G-code file's path to each.
    scripts = f"/bin/sh -c 'cp \"$0\" {before}'\n{GWEAVE} mix -c {profile} --in-place --no-backup"
    r = subprocess.run([slicer, "-g", "--layer-height", "0.2", "--post-process", scripts, str(MODEL), "-o", str(out)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    subprocess.run([str(GWEAVE), "mix", str(before), "-c", str(profile), "-o", str(cli)], check=True, capture_output=True)
    assert out.read_bytes() == cli.read_bytes()
    assert out.read_bytes() != before.read_bytes()
    assert b"; gweave mix:" in out.read_bytes()
