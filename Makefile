# The README's two commands: `make demo` and `make test`. Both work on a fresh clone:
# they create .venv, install what they need from PyPI and crates.io, and build the wheel.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: demo test setup build test-rust test-python bench nostd clean

setup: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet "maturin>=1.5,<2" "pytest>=7" "scipy>=1.9" "sympy>=1.11" "scikit-fuzzy>=0.4" \
		"numpy>=1.22" "tqdm>=4.60" "dask[distributed]>=2023.1" "mypy>=1.10" "pandas>=1.5" \
		"matplotlib>=3.5" "pillow>=9" "control>=0.10" "hypothesis>=6" "pytest-xdist>=3" \
		"gymnasium>=1.0"
	cargo fetch --locked 2>/dev/null || cargo fetch
	touch $(STAMP)

# Builds the extension in release mode into the venv (maturin develop = the wheel, installed).
build: setup
	$(VENV)/bin/maturin develop --release --quiet

# Regenerates the thesis's simulations, figures and tables into twip-report/.
demo: build
	$(VENV)/bin/twip reproduce

# The core is tested with std and its thread pool (all of it) and without std (the no_std
# subset), and the no_std build is checked for dependencies that switch std on; the
# benches beside the crate are built so that they cannot rot. They build in a target folder
# of their own, so that `make test` can run them while the wheel builds (cargo locks a
# target folder for the whole of a build), and without MAKEFLAGS: under `make --jobs` it names
# a jobserver that a recipe cannot reach, and rustdoc warned of it.
test-rust: export CARGO_TARGET_DIR := $(CURDIR)/target/tests
test-rust: MAKEFLAGS :=
test-rust: setup
	cargo test --workspace --exclude twip-py --features twip-core/parallel --quiet
	cargo test -p twip-core --no-default-features --lib --quiet
	scripts/check_nostd.sh
	cargo check -p twip-core --benches --examples --all-features --quiet
	cargo check -p twip-ffi --benches --quiet

# The tests run in parallel processes (pytest-xdist), one per core up to four: on a 2-core
# VM pytest took 196-250 s, and 276-312 s serially (separate runs). One test: `pytest -k name`.
PYTEST := $(PY) -m pytest tests -q -n auto --maxprocesses 4
test-python: build
	$(PYTEST)

# The wheel's build and the Rust tests run side by side, each cargo with both cores (most of
# the wheel's build is one rustc, twip-py's one codegen unit, which leaves a core idle), each
# printing its output whole when it ends. Measured on a clean clone, 2-core VM (with other
# work at nice 15 beside it): `make demo` 5 min 24 s to the report, then `make test` 12 min
# 26 s (pytest 241 s of it), at d2aa31f with the Rust tests at one job each; before it
# (9841fb6) a clean clone's `make demo` took 21 minutes and `make test` 1491 s, the wheel's
# build 13 min 50 s of CPU against 5 min 12 s now (the rigs' plant kinds compiled once per
# kernel copy, not inlined per controller law: sweep/block/mod.rs, `out_of_line_in`). With
# both cores each, a clean clone's `make test` alone (the wheel built in it, as CI does) took
# 12 min 47 s at 8fc6e2b (pytest 219 s of it). At 1280b0a (2 December, quiet VM) a clean clone's
# `make demo` took 11 min 28 s (the wheel's twip-py rustc alone ~11 min of CPU: this session's
# sized fuzzy laws, env batches and drive tallies in the kernels grew the .so's code 16 %), then
# `make test` 9 min 3 s (pytest 229 s, 1342 tests); `make test` with its own build (main, before
# the clean clone) 16 min 19 s. Both above the 8 and 12 min goals again.
test: setup
	$(MAKE) --no-print-directory --jobs=2 --output-sync=target test-rust build
	$(PYTEST)

nostd:
	cargo tree -p twip-core --no-default-features -e normal,features

bench: build
	cargo bench -p twip-core

clean:
	rm -rf $(VENV) target
