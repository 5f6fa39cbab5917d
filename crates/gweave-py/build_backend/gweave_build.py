"""The package's build backend: maturin's, with the `gweave` command built first.

A wheel built by maturin holds one Rust artefact of the crate it builds, here the extension module
`gweave._gweave` (maturin issue #368, "Ship both python library AND binary command line tool in
wheel"). The command is another crate (`gweave-cli`); this backend builds it with cargo, puts the
executable in the wheel's data directory (`[tool.maturin] data`, its `scripts/` folder: pip
installs those files next to the environment's `python`, on `PATH`), then hands over to maturin.
So `pip install ./crates/gweave-py` installs the same native `gweave` as `cargo install`, built
from the same checkout as the module, and the extension links no command-line code.

Both builds use one target folder and one profile, so the third-party libraries are shared,
but the engine (`gweave`, `gweave-sim`) is compiled once for each: the CLI's `clap` derive turns
on `syn`'s `full` feature, which changes the build of `serde_derive` and so of everything that
derives through it (measured on the debug build: 1.3 min for the command, then 3.5 min for the
module with PyO3).

The Makefile's `python` and `python-debug` run this file as a script before `maturin develop`
(`python gweave_build.py release|dev`), which does not go through a build backend.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any, Callable, Mapping, Optional

# crates/gweave-py: pyproject.toml's folder, where pip runs the backend.
PACKAGE = Path(__file__).resolve().parent.parent
# `[tool.maturin] data` in pyproject.toml.
SCRIPTS = PACKAGE / "wheel-data" / "scripts"


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


def __getattr__(name: str) -> Any:
    """Every other hook (sdist, metadata, requirements) is maturin's unchanged."""
    import maturin

    return getattr(maturin, name)


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: gweave_build.py PROFILE (cargo's: release, dev, guard...)")
    print(build_cli(sys.argv[1]))
