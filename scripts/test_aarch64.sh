#!/bin/sh
# Builds the core for aarch64 and runs its tests under qemu-user, with Debian's packages:
#
#   dpkg --add-architecture arm64 && apt-get update
#   apt-get install rustc-web cargo-web libstd-rust-web-dev:arm64 gcc-aarch64-linux-gnu qemu-user
#
# (measured with qemu-user 10.0.2 from bookworm-backports, 4 December 2026).
#
# rustup's toolchain has only the x86-64 standard library; Debian's `rustc-web` (1.96 in
# bookworm's updates, December 2026) ships an aarch64 one for its own rustc, so this uses
# Debian's rustc and cargo, not the ones first on PATH.
# The runner loads the aarch64 libc that libstd-rust-web-dev:arm64 installed (multiarch, under
# /lib): with -L /usr/aarch64-linux-gnu (the cross compiler's libc) its loader mixed the two, and
# the first thread a test started spun for ever. The tests run emulated: their times
# say nothing of an aarch64 CPU's speed.
#
# Usage: scripts/test_aarch64.sh [std|nostd|all]   (default all; the target dir is
# target/aarch64, apart from the host's).
set -eu

for tool in /usr/bin/rustc /usr/bin/cargo aarch64-linux-gnu-gcc qemu-aarch64; do
    command -v "$tool" >/dev/null || { echo "test_aarch64: $tool is missing (see the packages above)" >&2; exit 2; }
done
sysroot=$(/usr/bin/rustc --print sysroot)
[ -d "$sysroot/lib/rustlib/aarch64-unknown-linux-gnu" ] \
    || { echo "test_aarch64: /usr/bin/rustc has no aarch64 standard library (libstd-rust-web-dev:arm64)" >&2; exit 2; }

export RUSTC=/usr/bin/rustc RUSTDOC=/usr/bin/rustdoc
export CARGO_TARGET_AARCH64_UNKNOWN_LINUX_GNU_LINKER=aarch64-linux-gnu-gcc
export CARGO_TARGET_AARCH64_UNKNOWN_LINUX_GNU_RUNNER="qemu-aarch64 -L /"
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-target/aarch64}"
# Optimised, with debug assertions kept: emulated, unoptimised code runs slowly.
export CARGO_PROFILE_TEST_OPT_LEVEL=2 CARGO_PROFILE_DEV_OPT_LEVEL=2
cargo="/usr/bin/cargo test -p twip-core --target aarch64-unknown-linux-gnu --lib"

case "${1:-all}" in
    std) $cargo --features parallel ;;
    nostd) $cargo --no-default-features ;;
    all) $cargo --features parallel && $cargo --no-default-features ;;
    *) echo "test_aarch64: unknown part '$1' (std, nostd or all)" >&2; exit 2 ;;
esac
