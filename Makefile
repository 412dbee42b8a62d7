# The README's two commands: `make demo` and `make test`. Both work on a fresh clone:
# they create .venv, install what they need from PyPI and crates.io, and build the wheel.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
# The venv with pip and maturin, the crates fetched: enough to compile.
TOOLS := $(VENV)/.tools
# And every Python package the demo and the tests need.
STAMP := $(VENV)/.installed

.PHONY: demo test setup compile build test-rust test-python bench nostd clean

setup: $(STAMP)

$(TOOLS):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet "maturin>=1.5,<2"
	cargo fetch --locked 2>/dev/null || cargo fetch
	touch $(TOOLS)

$(STAMP): $(TOOLS) pyproject.toml
	$(PY) -m pip install --quiet "pytest>=7" "scipy>=1.9" "sympy>=1.11" "scikit-fuzzy>=0.4" \
		"numpy>=1.22" "tqdm>=4.60" "dask[distributed]>=2023.1" "mypy>=1.10" "pandas>=1.5" \
		"matplotlib>=3.5" "pillow>=9" "control>=0.10" "hypothesis>=6" "pytest-xdist>=3" \
		"gymnasium>=1.0"
	touch $(STAMP)

# The lane kernels' copies the wheel holds. On an x86-64 CPU with AVX2 and FMA (/proc/cpuinfo
# says), `host`: without the baseline copy (twip-core's `baseline-copy` feature), which only
# x86-64 CPUs without them run and which is a third of the kernels' optimiser time (LLVM's time
# trace at b44b0ea: 60 s of 187 s). The wheel's build from an empty target folder, one after the other
# on the 2-core Xeon: 366 s with it, 331 s without (twip-py's rustc 312 s against 269 s). `all`
# (elsewhere, or `make build KERNEL_COPIES=all`) builds a wheel for any x86-64 CPU, as
# `pip install .` and `maturin build` do. The Rust tests run every copy either way.
KERNEL_COPIES ?= $(if $(shell grep -qw avx2 /proc/cpuinfo 2>/dev/null && grep -qw fma /proc/cpuinfo && echo yes),host,all)
ifeq ($(filter $(KERNEL_COPIES),host all),)
$(error KERNEL_COPIES=$(KERNEL_COPIES): must be host or all)
endif
MATURIN := $(VENV)/bin/maturin develop --release --quiet $(if $(filter host,$(KERNEL_COPIES)),--no-default-features)

# Compiles the extension in place while pip installs the rest (`--skip-install`); `build` then
# finds it fresh and only installs it. Its cargo finds the cores itself (no jobserver, as
# test-rust below).
compile: MAKEFLAGS :=
compile: $(TOOLS)
	$(MATURIN) --skip-install

# Builds the extension in release mode into the venv (maturin develop = the wheel, installed).
build: setup compile
	$(MATURIN)

# Regenerates the thesis's simulations, figures and tables into twip-report/.
demo:
	$(MAKE) --no-print-directory --jobs=2 build
	$(VENV)/bin/twip reproduce

# The core is tested with std and its thread pool (all of it) and without std (the no_std
# subset), and the no_std build is checked for dependencies that switch std on; the
# benches (crates/twip-benches: criterion is no dependency of the cores' tests, see its
# Cargo.toml) and the examples are type-checked so that they cannot rot. The tests build in a target folder
# of their own, so that `make test` can run them while the wheel builds (cargo locks a
# target folder for the whole of a build), and without MAKEFLAGS: under `make --jobs` it names
# a jobserver that a recipe cannot reach, and rustdoc warned of it.
# The examples (release-build measuring tools) are only checked: `cargo test` alone builds
# them unoptimised too, with every kernel monomorphised again. Its units from a clean target
# folder (`--no-run`, 2-core VM, helpers' builds beside it): 300 s of CPU with the examples,
# 138 s without (sweep_throughput 92 s, env_throughput 46-58 s of unit time); one `cargo check`
# of both crates 53 s against 86 s for two.
test-rust: export CARGO_TARGET_DIR := $(CURDIR)/target/tests
test-rust: MAKEFLAGS :=
# Everything is built before anything runs: the builds are mostly one rustc at a time, which
# pytest's share of the cores fills beside them, while the test runs take both cores, so that
# no core is left idle at the end (at eee0fbe pytest ended first, and the no_std build and the
# check ran alone after it).
RUST_STD_TESTS := cargo test --workspace --exclude twip-py --features twip-core/parallel --quiet
RUST_NOSTD_TESTS := cargo test -p twip-core --no-default-features --lib --quiet
test-rust: $(TOOLS)
	$(RUST_STD_TESTS) --lib --bins --tests --no-run
	$(RUST_NOSTD_TESTS) --no-run
	scripts/check_nostd.sh
	cargo check -p twip-core -p twip-ffi -p twip-benches --benches --examples --features twip-core/parallel --quiet
	$(RUST_STD_TESTS) --lib --bins --tests
	$(RUST_STD_TESTS) --doc
	$(RUST_NOSTD_TESTS)

# The tests run in parallel processes (pytest-xdist), one per core up to four: on a 2-core
# VM pytest took 196-250 s, and 276-312 s serially (separate runs). One test: `pytest -k name`.
PYTEST := $(PY) -m pytest tests -q -n auto --maxprocesses 4
test-python: build
	$(PYTEST)

# The wheel's build and the Rust tests run side by side, each cargo with both cores (most of
# the wheel's build is one rustc, twip-py's one codegen unit, which leaves a core idle), each
# printing its output whole when it ends. Where that rustc's time went at 5184891 (LLVM's time
# trace: `RUSTC_BOOTSTRAP=1 cargo rustc --release -p twip-py --lib -- -Z llvm-time-trace`):
# 87 % of the optimiser's time in the twelve lane kernels that inline a fuzzy law (ideal and rig
# kernels with FuzzyLanes, planar ones with SmcLanes, 3 copies each), mostly loop rotation, SROA
# and full unrolling of the sized n x n laws' 49-rule loops. The sized laws now run out of line,
# once per kernel copy (sweep/block/mod.rs, `out_of_line_in`; the thesis's 3 x 3 stays inlined,
# which its speed needs). The same command, nice'd on the 2-core VM beside other builds (load
# 7-9): before, 856 s of CPU (the dependencies rebuilt with it), twip-py's LLVM passes 2,501 s
# of wall time; after, 264 s of CPU (twip-core, twip-ffi and twip-py only), LLVM passes 515 s.
# Clean clone on the quiet 2-core VM: before (1280b0a) `make demo` 11 min 28 s, then `make test`
# 9 min 3 s; after (e3c986c) `make demo` 5 min 45 s (345 s wall, 358 s user; the report 19.5 s
# of it), then `make test` 9 min 19 s (pytest 226 s, 1356 passed). Goals: 8 and 12 min.
# Clean clones since, on the same quiet 2-core VM, whose speed varies from day to day: 8ce8061
# `make demo` 358 s, then `make test` 710 s (pytest 555 s beside the Rust tests); eee0fbe (with
# the examples only checked, above, and more sysid and rig tests) `make demo` 469 s, then
# `make test` 781 s, on a day when the same wheel's build took 446 s against 336 s; 22cb25d (the
# lane tests' fewer debug-build blocks, criterion out of the cores' tests, every Rust build before
# the runs) `make demo` 429 s, then `make test` 675 s (pytest 576 s beside the Rust tests, whose
# lib suite ran 237 s against 400 s at eee0fbe); 443e4ee (OpenBLAS at one thread in pytest's
# workers, faster identification), with a helper's builds nice'd beside it, `make demo` 451 s,
# then `make test` 629 s (pytest 452 s beside the Rust tests).
#
# On this project's AVX2 machine (AMD EPYC, 2 cores; it does the same work with ~2.3x the CPU
# time of that VM), clean clone of c6a24c6 with other builds nice'd beside it: `make demo`
# 13 min 37 s (setup 78 s, the wheel 11 min 28 s at 828 s of CPU, the report 48 s), then
# `make test` 26 min 51 s (the Rust tests 15 min 36 s, then pytest 11 min 11 s, 884 s of CPU).
# Since then: pytest starts beside the Rust tests once the wheel is built, so neither leaves a
# core idle (the Rust tests' one-rustc phases, pytest's tail), and the longest test (the
# terrain's sympy derivation, 83 s) takes 23 s: clean clone of 36b8437, `make test` after demo
# 19 min 35 s (1,175 s wall, 2,116 s user; pytest 868 s beside the Rust tests), still over the
# goal on this machine. On the AVX-512 EPYC (4 December 2026): a fresh checkout of 36fed85,
# `make demo` 280 s, then `make test` 538 s (two other release builds beside it); a clean clone
# of 9d6e146, `make test` alone (CI's case, the wheel's build included) 580 s, pytest 181 s
# beside the Rust tests; a clean clone of d165eff (the runner on the lanes' loop), `make test`
# 535 s with a release build of the wheel beside it. Back on an AVX2-only EPYC (5 December 2026,
# nothing beside it): a clean clone of 7bcc665, `make demo` 341 s, then `make test` 496 s (pytest
# 429 s beside the Rust tests); a clean clone of 1e7ab55 (nineteenth session, nothing beside it),
# `make demo` 370 s, then `make test` 522 s (pytest 452 s beside the Rust tests), and one of
# e5b8ee7, `make test` alone (CI's case) 711 s. On the AVX-512 EPYC again (6 December 2026,
# nothing beside it): a clean clone of a4f32af, `make demo` 327 s, then `make test` 458 s
# (pytest 367 s beside the Rust tests, 1432 passed); a clean clone of 3c60614 (twenty-ninth
# session), `make test` alone (CI's case) 576 s; one of fc1fb35 (thirtieth), 566 s; one of
# 87d8884 (thirty-first), `make demo` 319 s, then `make test` 472 s (pytest 364 s); one of
# b619d55 (more rig kinds: a step's first try outside the stick band), `make demo` 319 s, then
# `make test` 416 s (pytest 336 s), and `make test` alone (CI's case) 627 s; one of c82994a (more
# for the first stage), `make demo` 305 s, then `make test` 398 s (pytest 319 s); one of e9d8512
# (docs since), `make test` alone 622 s; one of 46047c4, 659 s; one of d5d7807 (thirty-second
# session), `make test` alone 569 s (pytest 180 s); one of ecc2524 (the same code), 703 s (pytest
# 209 s): the VM's speed moves that much within an hour; one of 5613df6 (thirty-third session,
# docs only), 648 s (pytest 178 s); one of 6966f9e (the fuzzy weights' skip), 619 s (pytest
# 178 s); one of bfff89e (thirty-fourth session, each step written in place), 617 s (pytest
# 178 s); one of 1e38f69 (the same code), `make demo` 311 s, then `make test` 408 s; one of
# 3968687 (the envs' step in place), `make test` alone 740 s (its Rust lib tests ran 179 s against
# 159 s and pytest 193 s against 178 s at bfff89e: a slower hour); one of e326b02 (the review's
# mend), `make test` alone 670 s (pytest 176 s). On the AVX2-only Zen 3 EPYC (7 December 2026,
# thirty-fifth session): a clean clone of b8392ed, `make test` alone 853 s (pytest 261 s); another,
# `make demo` 445 s, then `make test` 556 s (pytest 451 s beside the Rust tests); one of c97f5d1
# (the review's mend), `make test` alone 794 s; thirty-sixth session, clean clones of b0723c3 (the
# fuzzy weights in place): `make demo` 383 s, then `make test` 615 s (pytest 510 s beside the
# Rust tests); `make test` alone 904 s (pytest 263 s); one of dbfc914 (the review's mend), `make
# test` alone 807 s (pytest 271 s); thirty-seventh session, in a slow hour (the LQR lanes 104 M
# sample-steps/s against 126-137 M), clean clones of 9dd9550: `make test` alone 1,041 s (pytest
# 345 s), and `make demo` 490 s, then `make test` 726 s; the wheels of 5ce0337 and 9dd9550 built
# side by side, 427 s and 424 s; thirty-eighth session, a quiet hour (the LQR lanes 141 M), a
# clean clone of 9580dfb (the rig steps written in place): `make demo` 408 s, then `make test`
# 599 s (pytest 479 s beside the Rust tests); one of 800ebaf, `make test` alone 783 s.
# Thirty-ninth session, the VM an Intel Xeon with AVX-512: a fresh checkout of 3e3c521 (no cargo
# registry, no pip cache), `make demo` 304 s, then `make test` 338 s (pytest 275 s beside the
# Rust tests); a clean clone of it, `make test` alone 533 s (pytest 149 s); one of 2e3e8fe (docs
# since), 525 s (pytest 148 s). Fortieth session, the same Xeon: a clean clone of 787c8a7, `make
# test` alone 546 s (pytest 156 s). Forty-first: one of 263550f, 576 s (pytest 167 s); one of
# 98809de (the input checks, 190 more Python tests), 602 s (pytest 1623 passed, 167 s); one of
# e4174d0, 634 s (pytest 1625 passed, 187 s); after the review's mends, one of 5270522, 673 s
# (pytest 184 s). Forty-second (the numeric audits' fixes, 470 more Python tests): one of fef686e,
# `make test` alone 823 s (the wheel ready after ~680 s beside the Rust tests, whose lib suite ran
# 175 s; pytest 2101 passed, 237 s); another, `make demo` 454 s, then `make test` 483 s (pytest
# 399 s beside the Rust tests). Not this session's code: `cargo build --release -p twip-py --lib`
# from an empty target folder, nothing beside it, took 362 s at 12e7628 and 365 s at fef686e
# (the thirty-ninth session's `make demo` of 304 s held the whole wheel). Forty-third (five
# audits' fixes, 133 more Python tests), clean clones of c0aa3df: `make test` alone 907 s (Rust
# lib suite 170 s; pytest 2234 passed, 267 s); another, `make demo` 676 s (the report 19 s, the
# rest the wheel), then `make test` 523 s (pytest 448 s beside the Rust tests); the same hour's
# benches on both cores ran 17-25 % below the last session's, one thread as fast, and 090acd8's
# `cargo build --release -p twip-py --lib` from an empty target, alone, took 434 s (365 s
# then). Forty-fourth (a report fix): a clean clone of b2efd15, `make demo` 511 s (the wheel ready at
# 485 s), then `make test` 583 s (pytest 487 s beside the Rust tests); the wheel alone from an empty
# target, 424 s (without LTO 367 s, but 3-5 % slower 2-DOF lanes: Cargo.toml, docs/performance.md);
# a clean clone of 0b57dc2, `make test` alone 1,437 s (Rust lib suite 178 s; pytest 2236 passed,
# 295 s against 224 s in the last session: a slower hour, the wheel ready only after ~19 min).
# Forty-fifth (the wheel without the baseline copy, `KERNEL_COPIES` above): a clean clone of
# 9fba6c3, `make demo` 358 s (the report 18 s), then `make test` 513 s (pytest 441 s beside the
# Rust tests); another, `make test` alone 663 s (Rust lib suite 165 s; pytest 2238 passed, 220 s);
# one of 239451c (a sweep result of another twip refused), `make test` alone 704 s (pytest 2242
# passed, 259 s).
# What was tried for the wheel is in Cargo.toml; built at
# opt-level 1, the Rust tests took 23 min (1,816 s of CPU) to compile, more than the whole of
# test-rust at opt-level 0 (15 min 36 s, with its runs).
test:
	$(MAKE) --no-print-directory --jobs=2 --output-sync=target test-python test-rust

nostd:
	cargo tree -p twip-core --no-default-features -e normal,features

bench: build
	cargo bench -p twip-benches

clean:
	rm -rf $(VENV) target
