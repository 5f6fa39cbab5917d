"""The package's build backend: maturin's, with the `gweave` command built first.

A wheel built by maturin holds one Rust artefact of the crate it builds, here the extension module
`gweave._gweave` (maturin issue #368, "Ship both python library AND binary command line tool in
wheel"). The command is another crate (`gweave-cli`); this backend builds it with cargo, puts the
executable in the wheel's data directory (`[tool.maturin] data`, its `scripts/` folder: pip
installs those files next to the environment's `python`, on `PATH`), then hands over to maturin.
So `pip install ./crates/gweave-py` installs the same native `gweave` as `cargo install`, built
from the same checkout as the module, and the extension links no command-line code.

Both builds use one target folder and one profile, so the third-party libraries and the engine
(`gweave`, `gweave-sim`) are compiled once for both. That holds because the module's crate
declares `syn` with its `full` feature (crates/gweave-py/Cargo.toml says why): the CLI's `clap`
derive turns it on, and without it the module's build resolved another `syn`, so another
`serde_derive` and everything that derives through it, the engine included (the module's debug
build took 108-124 s more).

The Makefile's `python` and `python-debug` run this file as a script before `maturin develop`
(`python gweave_build.py release|dev`), which does not go through a build backend; `make sdist`
runs it as `python gweave_build.py sdist DIR` (`maturin sdist` alone would leave out what
follows).

A source distribution is maturin's with what a wheel built from it also needs: this backend
(pyproject's `backend-path`, which maturin does not package), the command's crate as a member of
the packaged workspace (maturin packages only the module's own path dependencies, and refuses
`include` patterns outside the package's folder), and the built-in machine profiles the
simulator compiles in (`examples/machines`, `gweave machine list`).
"""

from __future__ import annotations

import io
import json
import os
import re
import shutil
import subprocess
import sys
import tarfile
from pathlib import Path
from typing import Any, Callable, Mapping, Optional

# crates/gweave-py: pyproject.toml's folder, where pip runs the backend.
PACKAGE = Path(__file__).resolve().parent.parent
# `[tool.maturin] data` in pyproject.toml.
SCRIPTS = PACKAGE / "wheel-data" / "scripts"
# The command's crate, beside this package in the workspace.
CLI_CRATE = "crates/gweave-cli"
# Folders of the workspace a build needs beside the crates maturin packages (the module's notes).
SDIST_EXTRAS = [CLI_CRATE, "examples/machines"]


def build_cli(profile: str = "release") -> Path:
    """Builds `gweave-cli` with cargo's `profile` and copies the executable to the wheel's
    scripts folder; returns the copy's path. Cargo's own error output goes to stderr."""
    cargo = os.environ.get("CARGO", "cargo")
    command = [cargo, "build", "-p", "gweave-cli", "--bin", "gweave", "--profile", profile]
    command += ["--message-format", "json-render-diagnostics"]
    # Cargo's JSON messages name the executable wherever the target folder is (CARGO_TARGET_DIR,
    # a workspace's target/, a `--target` triple).
    built = subprocess.run(command, cwd=PACKAGE, stdout=subprocess.PIPE, check=True, text=True)
    executable: Optional[str] = None
    for line in built.stdout.splitlines():
        message = json.loads(line)
        if message.get("reason") == "compiler-artifact" and message.get("executable"):
            executable = message["executable"]
    if executable is None:
        raise RuntimeError(f"{' '.join(command)}: cargo built no executable")
    SCRIPTS.mkdir(parents=True, exist_ok=True)
    target = SCRIPTS / Path(executable).name
    # Copied to a temporary name and renamed: an interrupted copy never leaves half a binary.
    partial = target.with_name(target.name + ".partial")
    shutil.copy2(executable, partial)
    os.replace(partial, target)
    return target


def maturin_profile(config_settings: Optional[Mapping[str, Any]]) -> str:
    """The cargo profile maturin builds the module with (`--profile` in `MATURIN_PEP517_ARGS` or
    the `build-args` config setting; else release, maturin's for a wheel), so that the command
    is built alike (and shares the third-party libraries the module's build compiles)."""
    import maturin

    args = maturin.get_maturin_pep517_args(config_settings)
    for i, arg in enumerate(args):
        if arg == "--profile" and i + 1 < len(args):
            return args[i + 1]
        if arg.startswith("--profile="):
            return arg.split("=", 1)[1]
    return "release"


def command_first(hook: str) -> Callable[..., str]:
    """maturin's PEP 517 `hook` (a wheel, or an editable wheel), run once the command is built."""

    def run(
        wheel_directory: str,
        config_settings: Optional[Mapping[str, Any]] = None,
        metadata_directory: Optional[str] = None,
    ) -> str:
        import maturin

        build_cli(maturin_profile(config_settings))
        built: str = getattr(maturin, hook)(wheel_directory, config_settings, metadata_directory)
        return built

    run.__name__ = hook
    return run


# The PEP 517 hooks: maturin's, each wheel built after the command.
build_wheel = command_first("build_wheel")
build_editable = command_first("build_editable")


def prepare_metadata_for_build_wheel(
    metadata_directory: str, config_settings: Optional[Mapping[str, Any]] = None
) -> str:
    """maturin's, once the data folder exists (maturin refuses a `data` folder that does not)."""
    import maturin

    SCRIPTS.mkdir(parents=True, exist_ok=True)
    return maturin.prepare_metadata_for_build_wheel(metadata_directory, config_settings)


def build_sdist(sdist_directory: str, config_settings: Optional[Mapping[str, Any]] = None) -> str:
    """maturin's source distribution, completed (the module's notes): a wheel builds from it."""
    import maturin

    name: str = maturin.build_sdist(sdist_directory, config_settings)
    complete_sdist(Path(sdist_directory) / name)
    return name


def complete_sdist(sdist: Path) -> None:
    """Adds this backend, the command's crate (to its workspace's members too) and the other
    `SDIST_EXTRAS` to the `.tar.gz` at `sdist`, written to a temporary name and renamed over
    it."""
    workspace = PACKAGE.parent.parent
    partial = sdist.with_name(sdist.name + ".partial")
    with tarfile.open(sdist, "r:gz") as old, tarfile.open(partial, "w:gz") as new:
        root = old.getnames()[0].split("/")[0]
        for member in old.getmembers():
            data = old.extractfile(member) if member.isfile() else None
            if member.name == f"{root}/Cargo.toml" and data is not None:
                manifest = with_member(data.read().decode(), CLI_CRATE).encode()
                member.size = len(manifest)
                data = io.BytesIO(manifest)
            new.addfile(member, data)
        extras = [(workspace / extra, extra) for extra in SDIST_EXTRAS]
        for folder, into in [(PACKAGE / "build_backend", "build_backend"), *extras]:
            for path in sorted(folder.rglob("*")):
                if path.is_file() and "__pycache__" not in path.parts:
                    new.add(path, f"{root}/{into}/{path.relative_to(folder).as_posix()}")
    os.replace(partial, sdist)


def with_member(manifest: str, crate: str) -> str:
    """The workspace `manifest` with `crate` among its `members`."""
    members = re.search(r"^members = \[([^\]]*)\]", manifest, re.MULTILINE)
    if members is None:
        raise RuntimeError("the source distribution's Cargo.toml has no workspace members")
    if f'"{crate}"' in members.group(1):
        return manifest
    listed = f'{members.group(1)}, "{crate}"' if members.group(1).strip() else f'"{crate}"'
    return manifest[: members.start(1)] + listed + manifest[members.end(1) :]


def __getattr__(name: str) -> Any:
    """Every other hook (metadata, requirements) is maturin's unchanged."""
    import maturin

    return getattr(maturin, name)


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "sdist":
        # `make sdist`: the completed source distribution, as a PEP 517 front end builds it
        # (from pyproject.toml's folder).
        out = Path(sys.argv[2]).resolve()
        os.chdir(PACKAGE)
        print(out / build_sdist(str(out)))
    elif len(sys.argv) == 2:
        print(build_cli(sys.argv[1]))
    else:
        sys.exit("usage: gweave_build.py PROFILE (cargo's: release, dev, guard...) | sdist DIR")
