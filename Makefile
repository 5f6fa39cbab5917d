# gweave: two set-up commands for a fresh machine.
#   make demo   builds the command line, then runs the main jobs on bundled real slicer output
#   make test   installs what is needed, then runs every test (cargo, pytest, end to end)
#   make bench  benchmarks on large real files, each figure beside a reference from the same run
#   make docs-images  draws the pictures of README.md and docs/ again with the current code
#   make fuzz   coverage-guided fuzzing of the reader, lexer, binary G-code, M503, profile loaders and controller core (not in make test)
#   make firmware  the firmware for Arduino Mega 2560 + RAMPS 1.4 (firmware/out/gweave-ramps.hex)
#   make firmware-cortex  the firmware for a 32-bit STM32F4 board (firmware/out/gweave-cortex.bin)

SHELL := /bin/bash
.SHELLFLAGS := -eu -o pipefail -c
VENV := .venv
PY := $(VENV)/bin/python
CARGO := cargo
# The release binary, where cargo puts it (a CARGO_TARGET_DIR of the user's moves it).
GWEAVE := $(or $(CARGO_TARGET_DIR),target)/release/gweave
OUT := out

.PHONY: demo test bench deps rust-deps python-deps py-deps build build-debug python python-debug lint cargo-test pytest e2e clean
.PHONY: browser-deps cura-deps fuzz docs-images firmware firmware-deps firmware-fault firmware-test firmware-cortex
.PHONY: guard sdist rust-and-python-tests

deps: rust-deps py-deps browser-deps cura-deps firmware-deps

# apt-get for the system packages (as root), one at a time even under `make -j`: a second
# apt-get fails at once on the lock the first holds (`apt-get update` ignores
# DPkg::Lock::Timeout), so each waits for the others on a lock file of our own.
APT_GET := flock /var/lock/gweave-apt.lock apt-get

rust-deps:
	@command -v $(CARGO) >/dev/null || { echo "cargo is needed (Rust 1.80 or newer)"; exit 1; }

# What the Python package needs to be built and used (`make python`): maturin and NumPy.
python-deps: $(VENV)/.python-deps
$(VENV)/.python-deps: crates/gweave-py/requirements.txt
	python3 -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -r crates/gweave-py/requirements.txt
	touch $@

# Everything the tests need on top (pytest, mypy, the hosts and OctoPrint's web server).
py-deps: $(VENV)/.deps
$(VENV)/.deps: $(VENV)/.python-deps crates/gweave-py/requirements-dev.txt crates/gweave-py/requirements-host.txt crates/gweave-py/requirements-octoprint.txt
	$(PY) -m pip install -q -r crates/gweave-py/requirements-dev.txt
	# OctoPrint with its dependencies (a whole web server), before Printrun, whose pins it would
	# otherwise fight: the host of test_octoprint_serve.py and of the plugin's test_octoprint.py.
	$(PY) -m pip install -q -r crates/gweave-py/requirements-octoprint.txt
	# Printrun's printcore without its GUI dependencies (see the file).
	$(PY) -m pip install -q --no-deps -r crates/gweave-py/requirements-host.txt
	touch $@

# Headless chromium for the HTML viewer test (crates/gweave-py/tests/test_viewer.py); installed only
# when running as root, otherwise the test says why it skips.
browser-deps:
	@if [ -x /usr/bin/chromium ]; then :; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	  $(APT_GET) install -y -q chromium || { $(APT_GET) update -q && $(APT_GET) install -y -q chromium; }; \
	else echo "browser-deps: no /usr/bin/chromium and not root: the viewer test will be skipped"; fi

# Debian's Cura 4.13 (its PostProcessingPlugin and Uranium) for the Cura script's test
# (crates/gweave-py/tests/test_cura.py); installed only when running as root, otherwise the test
# says why it skips.
cura-deps:
	@if [ -f /usr/lib/cura/plugins/PostProcessingPlugin/Script.py ]; then :; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	  $(APT_GET) install -y -q --no-install-recommends cura || { $(APT_GET) update -q && $(APT_GET) install -y -q --no-install-recommends cura; }; \
	else echo "cura-deps: no Debian cura package and not root: the Cura script test will be skipped"; fi

# The firmware (docs/firmware.md): Debian's Rust (rustc-web 1.96 with the library source, which
# builds `core` for the AVR; rustup's toolchains ship no AVR target), avr-gcc to link, and
# libsimavr for the emulated board of the tests. Installed with apt-get when running as root.
# The 32-bit build links with LLVM's lld (rust-web-llvm's `rust-lld` points to lld-22's) and
# runs in the tests on qemu-system-arm's Netduino Plus 2 (an STM32F405).
FW_PACKAGES := rustc-web cargo-web rust-web-src rust-web-llvm gcc-avr avr-libc binutils-avr simavr \
  libsimavr-dev lld-22 llvm-22 qemu-system-arm
FW_OUT := firmware/out
# Its own target folder: another compiler and another target than the workspace's. Every AVR
# image shares it, so `core` is built for the AVR once (40 s on two cores) and each image after
# it takes seconds (a folder per image built `core` five times: over 3 minutes of `make test`).
FW_TARGET_DIR ?= $(CURDIR)/target/avr

firmware-deps:
	@missing=""; for p in $(FW_PACKAGES); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "ok installed" || missing="$$missing $$p"; \
	done; \
	if [ -z "$$missing" ]; then :; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	  $(APT_GET) install -y -q --no-install-recommends $$missing || { $(APT_GET) update -q && $(APT_GET) install -y -q --no-install-recommends $$missing; }; \
	else echo "firmware-deps: missing$$missing (install them as root: apt-get install$$missing)"; exit 1; fi

# One image per printer file and features: $(call fw_image,NAME,TOML,FEATURES) builds
# firmware/TOML with the cargo FEATURES into $(FW_OUT)/NAME.elf and .hex. The printer's settings
# are constants of the build (firmware/ramps/build.rs): the base and the mixing image (the same
# features, two printer files) rebuild each other's last crate, a few seconds each.
define fw_image
	cd firmware/ramps && GWEAVE_PRINTER=$(2) CARGO_TARGET_DIR=$(FW_TARGET_DIR) RUSTC=/usr/bin/rustc \
	  RUSTC_BOOTSTRAP=1 /usr/bin/cargo build --release -q --features "$(3)"
	@mkdir -p $(FW_OUT)
	cp $(FW_TARGET_DIR)/avr-none/release/gweave-ramps.elf $(FW_OUT)/$(1).elf
	avr-objcopy -O ihex -R .eeprom $(FW_OUT)/$(1).elf $(FW_OUT)/$(1).hex
	@avr-size $(FW_OUT)/$(1).elf
endef

# The default printer (firmware/printer.toml), the same printer with a 4-input mixing hotend
# (firmware/printer-mixing.toml), with two hotends and extruders (RAMPS "EEB",
# firmware/printer-eeb.toml), an inkjet printer (M700 through an InkShield, docs/firmware.md
# "Inkjet"), and a lathe-type printer (the rotary axis A on E1's socket,
# firmware/printer-rotary.toml, docs/firmware.md "Rotary").
firmware: firmware-deps
	$(call fw_image,gweave-ramps,printer.toml,)
	$(call fw_image,gweave-ramps-mixing,printer-mixing.toml,)
	$(call fw_image,gweave-ramps-eeb,printer-eeb.toml,)
	$(call fw_image,gweave-ramps-inkjet,printer.toml,inkjet)
	$(call fw_image,gweave-ramps-rotary,printer-rotary.toml,rotary)

# The same core for a Cortex-M4F (STM32F405/F407, BTT SKR Pro's pin map; docs/firmware.md):
# the ELF for QEMU and debuggers, the raw .bin a board's bootloader or st-flash writes at
# 0x08000000.
FW_CORTEX_ELF := $(FW_OUT)/gweave-cortex.elf
FW_CORTEX_TARGET_DIR ?= $(CURDIR)/target/cortex
firmware-cortex: firmware-deps
	cd firmware/cortex && CARGO_TARGET_DIR=$(FW_CORTEX_TARGET_DIR) RUSTC=/usr/bin/rustc RUSTC_BOOTSTRAP=1 \
	  /usr/bin/cargo build --release -q
	@mkdir -p $(FW_OUT)
	cp $(FW_CORTEX_TARGET_DIR)/thumbv7em-none-eabihf/release/gweave-cortex $(FW_CORTEX_ELF)
	llvm-objcopy-22 -O binary $(FW_CORTEX_ELF) $(FW_OUT)/gweave-cortex.bin
	@llvm-size-22 $(FW_CORTEX_ELF)


# The test image: the firmware with `M9999` hanging its main loop (feature fault-injection),
# for the emulated board's watchdog test, built for a RAMPS "EEB" printer (a second hotend on
# D9, firmware/printer-eeb.toml) so the board tests heat the second hotend without a 4th image.
firmware-fault: firmware-deps
	$(call fw_image,gweave-ramps-fault,printer-eeb.toml,fault-injection)

build: rust-deps
	$(CARGO) build --release -p gweave-cli

# Tests use debug builds (dependencies are optimised, see Cargo.toml) to keep CI short.
build-debug: rust-deps
	$(CARGO) build -p gweave-cli

# The package's `gweave` command is the CLI's executable, built first into the wheel's data by
# the package's build backend (crates/gweave-py/build_backend/gweave_build.py), which
# `maturin develop` does not run.
python: python-deps
	$(PY) crates/gweave-py/build_backend/gweave_build.py release >/dev/null
	$(VENV)/bin/maturin develop --release -q -m crates/gweave-py/Cargo.toml

python-debug: py-deps
	$(PY) crates/gweave-py/build_backend/gweave_build.py dev >/dev/null
	$(VENV)/bin/maturin develop -q -m crates/gweave-py/Cargo.toml

# The Python package's source distribution, in dist/ (what `pip install gweave-*.tar.gz` builds from).
sdist: py-deps
	PATH=$(abspath $(VENV))/bin:$$PATH $(PY) crates/gweave-py/build_backend/gweave_build.py sdist dist

lint: rust-deps
	$(CARGO) fmt --all -- --check
	$(CARGO) fmt --manifest-path firmware/ramps/Cargo.toml -- --check
	$(CARGO) fmt --manifest-path firmware/cortex/Cargo.toml -- --check
	$(CARGO) clippy --workspace --all-targets -- -D warnings
	# Broken or private links in the API docs fail too, and broken links in the docs of private
	# items (what a contributor reads beside the code).
	RUSTDOCFLAGS="-D warnings" $(CARGO) doc --workspace --no-deps --exclude gweave-py -q
	RUSTDOCFLAGS="-D warnings" $(CARGO) doc --workspace --no-deps --exclude gweave-py -q --document-private-items

# The emulated boards' tests (crates/gweave-board/tests) run the firmware `make firmware`,
# `make firmware-fault` and `make firmware-cortex` built (tests/cortex.rs starts QEMU: about 2 s).
RUST_TESTS := $(CARGO) test --workspace --exclude gweave-py
cargo-test: rust-deps firmware firmware-fault firmware-cortex
	$(RUST_TESTS)

# The package's annotations agree with the compiled module's stub (_gweave.pyi); pytest takes
# whole test files to one worker a core (a file's OctoPrint or browser starts once). Exit code 5
# (no tests collected) is a failure here, as every other non-zero code.
# The tests that measure speed (marked `timed`: the viewer's frame rate) run alone afterwards,
# on a quiet machine.
MYPY := $(PY) -m mypy crates/gweave-py/python/gweave
PYTEST := $(PY) -m pytest crates/gweave-py/tests -q -n auto --dist loadfile -m 'not timed'
PYTEST_TIMED := $(PY) -m pytest crates/gweave-py/tests -q -m timed
pytest: python-debug
	$(MYPY)
	$(PYTEST)
	$(PYTEST_TIMED)

# `make test` runs the two side by side once both are built: pytest mostly waits on its servers,
# its browser and its hosts while the Rust tests keep both cores busy, so on two cores this takes
# two minutes less than one after the other (README.md, "Set up and run", says how long `make
# test` takes). pytest's output is kept and shown after the Rust tests'; the timed tests follow.
rust-and-python-tests: rust-deps firmware firmware-fault firmware-cortex python-debug
	$(RUST_TESTS) --no-run
	@log=$$(mktemp); ( $(MYPY) && $(PYTEST) ) > $$log 2>&1 & pytests=$$!; \
	rust=0; $(RUST_TESTS) || rust=$$?; \
	python=0; wait $$pytests || python=$$?; \
	echo "mypy and pytest (run beside the Rust tests):"; cat $$log; rm -f $$log; \
	[ $$rust = 0 ] && [ $$python = 0 ]
	$(PYTEST_TIMED)

e2e: build-debug python-debug
	bash tests/e2e/run.sh target/debug/gweave

# The performance guard: instructions per line (callgrind) of the hot commands on a fixed input
# against bench/guard-baseline.txt, failing past +15 % (bench/guard.sh; docs/performance.md). It
# measures the `guard` profile (release without fat LTO: minutes less to build than `release`).
guard: rust-deps
	@command -v valgrind >/dev/null || { [ "$$(id -u)" = 0 ] && $(APT_GET) install -y -q valgrind >/dev/null; } || true
	$(CARGO) build --profile guard -p gweave-cli
	bash bench/guard.sh $${CARGO_TARGET_DIR:-target}/guard/gweave

# pip (mostly downloads) runs beside `make lint` (clippy keeps both cores busy): about 40 s less.
# The system packages come first.
test: rust-deps browser-deps cura-deps firmware-deps
	$(MAKE) -j2 py-deps lint
	$(MAKE) rust-and-python-tests e2e guard
	@echo "make test: all passed"

# The demo runs the command line only: one release build of the engine, no Python environment
# (README.md says how long it takes from a fresh clone).
demo: build
	bash examples/demo.sh $(GWEAVE) $(OUT)

# The whole benchmark (docs/performance.md); the firmware's budgets are read from its images.
bench: build python firmware
	bash bench/run.sh $(GWEAVE)

docs-images: build
	bash scripts/docs_images.sh $(GWEAVE)

# Coverage-guided fuzzing with AFL++ (cargo-afl, stable toolchain), FUZZ_SECONDS per target, one
# process at a time, niced. Each run starts from the kept corpus (fuzz/corpus/<target>/) and leaves
# its queue and findings in fuzz/out/<target>/; a crash fails the run, to be kept in
# fuzz/crashes/<target>/ (docs/reliability.md, "Fuzzing").
FUZZ_SECONDS ?= 60
FUZZ_TARGETS := gcode bgcode m503 machine_profile mix_profile printhead_profile controller_reader controller
FUZZ_ENV := AFL_NO_UI=1 AFL_SKIP_CPUFREQ=1 AFL_NO_AFFINITY=1 AFL_AUTORESUME=1 \
	AFL_I_DONT_CARE_ABOUT_MISSING_CRASHES=1

fuzz: rust-deps
	@command -v cargo-afl >/dev/null || $(CARGO) install --locked cargo-afl
	@# Installing cargo-afl builds AFL++; this builds it only where that did not happen.
	@$(CARGO) afl config --build >/dev/null 2>&1 || true
	cd fuzz && nice -n 19 $(CARGO) afl build --release
	@mkdir -p fuzz/out
	@for t in $(FUZZ_TARGETS); do \
	  echo "fuzz: $$t for $(FUZZ_SECONDS) s (log: fuzz/out/$$t.log)"; \
	  (cd fuzz && $(FUZZ_ENV) nice -n 19 $(CARGO) afl fuzz -V $(FUZZ_SECONDS) -t 2000 \
	    -i corpus/$$t -o out/$$t target/release/$$t >out/$$t.log 2>&1) \
	    || { tail -20 fuzz/out/$$t.log; exit 1; }; \
	done
	@found=$$(find fuzz/out/*/default/crashes fuzz/out/*/default/hangs -name 'id:*' 2>/dev/null); \
	if [ -n "$$found" ]; then \
	  echo "fuzz: found (keep each in fuzz/crashes/<target>/ and fix):"; echo "$$found"; exit 1; \
	fi; echo "fuzz: no crash and no hang in $(FUZZ_TARGETS)"

clean:
	rm -rf $(OUT) $(VENV)
	$(CARGO) clean
