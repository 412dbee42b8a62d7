#!/bin/sh
# What a firmware built from `twip export` takes, measured on the host: twip-ffi built as a
# firmware builds it (no std, panic-halt, panic=abort), the exported example.c linked against
# it with unused sections dropped, for one scenario of each family. Prints the text, data and
# bss of the whole program and the bytes of its twip symbols. x86-64 code; Thumb-2 differs.
#   scripts/firmware_size.sh [scenario ...]
set -eu
cd "$(dirname "$0")/.."
ROOT=$(pwd)
OUT=${TMPDIR:-/tmp}/twip-firmware-size
TARGET="$OUT/target"
mkdir -p "$OUT"
CARGO_TARGET_DIR="$TARGET" cargo rustc -p twip-ffi --release --quiet --no-default-features \
    --features panic-halt --crate-type staticlib -- -C panic=abort
LIB="$TARGET/release/libtwip_ffi.a"
echo "no_std libtwip_ffi.a: $(wc -c < "$LIB") bytes (archive, before linking)"
printf "%-18s %8s %6s %6s %12s\n" scenario text data bss twip_symbols
for s in "${@:-flat-lqr flat-fuzzy circle-pid circle-smc-fuzzy}"; do
  for name in $s; do
    dir="$OUT/$name"
    "$ROOT/.venv/bin/twip" export "$name" --out "$dir" --replay-seconds 0.1 2>/dev/null
    cc -O2 -std=c11 -ffunction-sections -fdata-sections -DTWIP_HOST_MAIN -I"$dir" \
        "$dir/example.c" "$dir/twip_config.c" "$LIB" -lm -Wl,--gc-sections -o "$dir/example"
    "$dir/example" > /dev/null
    set -- $(size "$dir/example" | tail -1)
    twip=$(nm -S -t d "$dir/example" | awk '$3 ~ /^[tT]$/ && $4 ~ /twip/ {s += $2} END {print s + 0}')
    printf "%-18s %8s %6s %6s %12s\n" "$name" "$1" "$2" "$3" "$twip"
  done
done
