#!/bin/sh
# Configures, builds and runs the whole test suite on the repository's data/ (or $KNEESIM_DATA_DIR, a
# folder with the same layout). A test whose data file is missing fails; none skips.
set -eu
cd "$(dirname "$0")/.."
data="${KNEESIM_DATA_DIR:-$(pwd)/data}"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DKNEESIM_DATA_DIR="$data" >/dev/null
cmake --build build -j"$(nproc)"
ctest --test-dir build --output-on-failure -j"$(nproc)" "$@"
