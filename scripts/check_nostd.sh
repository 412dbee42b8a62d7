#!/usr/bin/env bash
# The core must build without std, and no dependency may switch std on in that build.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build -p twip-core --no-default-features --quiet
if cargo tree -p twip-core --no-default-features -e normal,features --prefix none | grep -i 'feature "std"'; then
    echo "check_nostd: a dependency enables std in the no_std build (above)" >&2
    exit 1
fi
echo "check_nostd: twip-core builds without std, and nothing enables std"
