"""The Cura post-processing script (integrations/cura/Gweave.py) inside Cura's own script machinery.

Debian's ``cura`` package (Cura 4.13, installed by ``make cura-deps`` as root) provides the
PostProcessingPlugin's ``Script`` base class and Uranium, for the system Python. The harness
(integrations/cura/harness.py) runs there: it loads the script as Cura's plugin does, lets
Uranium parse its settings, sets them and calls ``execute`` on CuraEngine's output cut into
Cura's layer list. What Cura would save must equal what the CLI writes on the same file.
"""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import gweave

ROOT = Path(__file__).resolve().parents[3]
HARNESS = ROOT / "integrations" / "cura" / "harness.py"
SCRIPT_PY = Path("/usr/lib/cura/plugins/PostProcessingPlugin/Script.py")
SYSTEM_PYTHON = "/usr/bin/python3"


@pytest.fixture(scope="module")
def cura_python(tmp_path_factory):
    """The system Python with Uranium, and a folder holding this gweave package for it."""
    if not SCRIPT_PY.exists():
        why = "Cura's PostProcessingPlugin is not installed; run `make cura-deps` as root (apt-get install cura)"
        print(why)
        pytest.skip(why)
    probe = subprocess.run([SYSTEM_PYTHON, "-c", "import UM.Settings.ContainerRegistry"], capture_output=True)
    assert probe.returncode == 0, probe.stderr.decode()
    # The package alone (compiled for the stable ABI, any Python 3.8+), not this environment's
    # site-packages, so the system Python sees nothing else of it.
    pkgs = tmp_path_factory.mktemp("pkgs")
    shutil.copytree(Path(gweave.__file__).parent, pkgs / "gweave")
    return pkgs


def harness(gcode: Path, out: Path, settings: dict, env: dict) -> subprocess.CompletedProcess:
    return subprocess.run([SYSTEM_PYTHON, str(HARNESS), str(gcode), str(out), json.dumps(settings)],
                          capture_output=True, text=True, timeout=300, env=env)


def in_cura(pkgs: Path, gcode: Path, out: Path, settings: dict) -> dict:
    r = harness(gcode, out, settings, {"PYTHONPATH": str(pkgs), "PATH": "/usr/bin:/bin"})
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


def test_cura_script_purge_shift_equals_the_cli(cura_python, cura_one_nozzle, tmp_path):
    fixture = cura_one_nozzle
    pieces = in_cura(cura_python, fixture, tmp_path / "cura.gcode", {"mode": "purge-shift", "purge_mm": 2.5})
    # Cura's list comes back as long, each piece starting where it did (one per layer).
    assert pieces == {"pieces_in": 206, "pieces_out": 206, "firsts_equal": True}
    gweave.purge_shift(fixture, tmp_path / "cli.gcode", purge_mm=2.5)
    got = (tmp_path / "cura.gcode").read_bytes()
    assert got == (tmp_path / "cli.gcode").read_bytes()
    assert got != fixture.read_bytes()


def test_cura_script_mix_equals_the_cli(cura_python, data, tmp_path):
    fixture = data / "cura" / "cura_torus.gcode"
    profile = ROOT / "examples" / "mix" / "seed_layers.toml"
    pieces = in_cura(cura_python, fixture, tmp_path / "cura.gcode", {"mode": "mix", "mix_profile": str(profile)})
    assert pieces == {"pieces_in": 30, "pieces_out": 30, "firsts_equal": True}
    gweave.mix(fixture, tmp_path / "cli.gcode", config=profile)
    assert (tmp_path / "cura.gcode").read_bytes() == (tmp_path / "cli.gcode").read_bytes()


def test_cura_script_without_a_mix_profile_says_so(cura_python, data, tmp_path):
    r = harness(data / "cura" / "cura_torus.gcode", tmp_path / "o.gcode", {"mode": "mix"},
                {"PYTHONPATH": str(cura_python), "PATH": "/usr/bin:/bin"})
    assert r.returncode == 1
    assert "gweave: set the mix profile (a TOML file) in the script's settings" in r.stderr


def test_cura_script_reports_gweave_error(cura_python, data, tmp_path):
    r = harness(data / "cura" / "cura_torus.gcode", tmp_path / "o.gcode",
                {"mode": "mix", "mix_profile": "/nonexistent/mix.toml"},
                {"PYTHONPATH": str(cura_python), "PATH": "/usr/bin:/bin"})
    assert r.returncode == 1 and not (tmp_path / "o.gcode").exists()
    assert "No such file or directory: '/nonexistent/mix.toml'" in r.stderr, r.stderr[-2000:]


def test_cura_script_falls_back_to_the_gweave_command(cura_python, cura_one_nozzle, tmp_path):
    """Cura's Python without the package (the AppImage): the `gweave` command on PATH does the job."""
    fixture = cura_one_nozzle
    r = harness(fixture, tmp_path / "cura.gcode", {"mode": "purge-shift", "purge_mm": 2.5},
                {"PATH": f"{Path(sys.executable).parent}:/usr/bin:/bin"})
    assert r.returncode == 0, r.stderr[-3000:]
    gweave.purge_shift(fixture, tmp_path / "cli.gcode", purge_mm=2.5)
    assert (tmp_path / "cura.gcode").read_bytes() == (tmp_path / "cli.gcode").read_bytes()


def test_the_scripts_install_line_names_no_pypi_package():
    # The header said `pip install gweave`: that name on PyPI is not ours (docs/integrations.md).
    header = (ROOT / "integrations" / "cura" / "Gweave.py").read_text().split("\nimport ")[0]
    assert "pip install gweave" not in header
    assert "pip install ./crates/gweave-py" in header
