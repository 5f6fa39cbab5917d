# gweave: two set-up commands for a fresh machine.
#   make demo   installs what is needed, then runs the main jobs on bundled real slicer output
#   make test   installs what is needed, then runs every test (cargo, pytest, end to end)
#   make bench  benchmarks on large real files, each figure beside a reference from the same run

SHELL := /bin/bash
.SHELLFLAGS := -eu -o pipefail -c
VENV := .venv
PY := $(VENV)/bin/python
CARGO := cargo
GWEAVE := target/release/gweave
OUT := out

.PHONY: demo test bench deps rust-deps py-deps build build-debug python python-debug lint cargo-test pytest e2e clean
.PHONY: browser-deps

deps: rust-deps py-deps browser-deps

rust-deps:
	@command -v $(CARGO) >/dev/null || { echo "cargo is needed (Rust 1.80 or newer)"; exit 1; }

py-deps: $(VENV)/.deps
$(VENV)/.deps: crates/gweave-py/requirements-dev.txt crates/gweave-py/requirements-host.txt crates/gweave-py/requirements-octoprint.txt
	python3 -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -r crates/gweave-py/requirements-dev.txt
	# Printrun's printcore without its GUI dependencies (see the file).
	$(PY) -m pip install -q --no-deps -r crates/gweave-py/requirements-host.txt
	# OctoPrint with its dependencies, for test_octoprint_serve.py.
	$(PY) -m pip install -q -r crates/gweave-py/requirements-octoprint.txt
	touch $@

# Headless chromium for the HTML viewer test (crates/gweave-py/tests/test_viewer.py); installed only
# when running as root, otherwise the test says why it skips.
browser-deps:
	@if [ -x /usr/bin/chromium ]; then :; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	  apt-get install -y -q chromium || { apt-get update -q && apt-get install -y -q chromium; }; \
	else echo "browser-deps: no /usr/bin/chromium and not root: the viewer test will be skipped"; fi

build: rust-deps
	$(CARGO) build --release -p gweave-cli

# Tests use debug builds (dependencies are optimised, see Cargo.toml) to keep CI short.
build-debug: rust-deps
	$(CARGO) build -p gweave-cli

python: py-deps
	$(VENV)/bin/maturin develop --release -q -m crates/gweave-py/Cargo.toml

python-debug: py-deps
	$(VENV)/bin/maturin develop -q -m crates/gweave-py/Cargo.toml

lint: rust-deps
	$(CARGO) fmt --all -- --check
	$(CARGO) clippy --workspace --all-targets -- -D warnings
	# Broken or private links in the API docs fail too.
	RUSTDOCFLAGS="-D warnings" $(CARGO) doc --workspace --no-deps --exclude gweave-py -q

cargo-test: rust-deps
	$(CARGO) test --workspace --exclude gweave-py

pytest: python-debug
	# Exit code 5 (no tests collected) is a failure here, as every other non-zero code.
	$(PY) -m pytest crates/gweave-py/tests -q

e2e: build-debug python-debug
	bash tests/e2e/run.sh target/debug/gweave

test: deps lint cargo-test pytest e2e
	@echo "make test: all passed"

demo: build python
	bash examples/demo.sh $(GWEAVE) $(OUT)

bench: build python
	bash bench/run.sh $(GWEAVE)

clean:
	rm -rf $(OUT) $(VENV)
	$(CARGO) clean
