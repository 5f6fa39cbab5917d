from pathlib import Path

import pytest

DATA = Path(__file__).resolve().parents[3] / "tests" / "data"


@pytest.fixture
def data() -> Path:
    return DATA


@pytest.fixture
def cura_one_nozzle(tmp_path) -> Path:
    """Cura's dual-extrusion fixture as for one nozzle: purge-shift refuses it as sliced (a
    nozzle per tool, shown by its `M104 T1 S215` preheats and standbys), so those lines are made
    comments, as `gweave mix` does (crates/gweave/tests/one_nozzle/mod.rs does the same for the
    Rust tests). Every other byte, and the line count, is the file's."""
    lines = (DATA / "cura" / "cura_dual.gcode").read_bytes().splitlines(keepends=True)
    path = tmp_path / "cura_one_nozzle.gcode"
    path.write_bytes(b"".join(b";" + l if l.startswith((b"M104 T", b"M109 T")) else l for l in lines))
    return path
