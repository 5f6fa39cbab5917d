"""The source distribution holds what building a wheel from it needs.

maturin packages the module's crate and its path dependencies, not the build backend that
`pyproject.toml`'s `backend-path` names nor the command's crate (`gweave-cli`), which the
backend builds into the wheel, nor the built-in machine profiles the simulator compiles in: `pip
install gweave-0.1.0.tar.gz` failed. Building the wheel takes minutes (the engine twice); this test checks the
archive and that cargo reads its workspace with the command in it.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tarfile
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(PACKAGE / "build_backend"))

import gweave_build  # noqa: E402


def test_the_sdist_carries_the_backend_and_the_command_crate(tmp_path, monkeypatch):
    # maturin's Python hooks run the `maturin` executable installed beside this interpreter.
    monkeypatch.setenv("PATH", f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}")
    monkeypatch.chdir(PACKAGE)
    name = gweave_build.build_sdist(str(tmp_path))
    with tarfile.open(tmp_path / name) as sdist:
        sdist.extractall(tmp_path / "unpacked", filter="data")
    root = tmp_path / "unpacked" / name.removesuffix(".tar.gz")

    pyproject = (root / "pyproject.toml").read_text()
    assert 'backend-path = ["build_backend"]' in pyproject
    assert (root / "build_backend" / "gweave_build.py").read_bytes() == (
        PACKAGE / "build_backend" / "gweave_build.py"
    ).read_bytes()
    cli = PACKAGE.parent / "gweave-cli"
    for part in ["Cargo.toml", "src/main.rs", "src/lib.rs"]:
        assert (root / "crates/gweave-cli" / part).read_bytes() == (cli / part).read_bytes(), part
    # The simulator compiles the built-in machine profiles in (`include_str!`).
    machines = PACKAGE.parent.parent / "examples" / "machines"
    assert sorted(p.name for p in (root / "examples" / "machines").iterdir()) == sorted(
        p.name for p in machines.iterdir()
    )

    # Cargo sees the command's crate as a member, with its binary, from the archive's lock file.
    metadata = subprocess.run(
        ["cargo", "metadata", "--format-version", "1", "--no-deps", "--offline"],
        cwd=root,
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    packages = {p["name"]: p for p in json.loads(metadata)["packages"]}
    binaries = [t["name"] for t in packages["gweave-cli"]["targets"] if t["kind"] == ["bin"]]
    assert binaries == ["gweave"]
