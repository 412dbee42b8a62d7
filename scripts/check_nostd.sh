#!/usr/bin/env bash
# The core and the C ABI must build without std, and no dependency may switch std on in
# those builds. (twip-ffi's staticlib needs a panic handler, which a firmware's target
# gives with --features panic-halt; on the host its rlib shows the code is no_std.)
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build -p twip-core --no-default-features --quiet
cargo rustc -p twip-ffi --no-default-features --lib --crate-type rlib --quiet
for crate in twip-core twip-ffi; do
    if cargo tree -p "$crate" --no-default-features -e normal,features --prefix none | grep -i 'feature "std"'; then
        echo "check_nostd: a dependency enables std in the no_std build of $crate (above)" >&2
        exit 1
    fi
done
echo "check_nostd: twip-core and twip-ffi build without std, and nothing enables std"
