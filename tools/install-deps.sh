#!/bin/sh
# Installs kneesim's build and run dependencies from Debian 12 packages. Idempotent; run as root.
# slurm-wlm and munge are for the test of `kneesim batch --emit-slurm` on a single-node Slurm
# (tests/cli/batch_slurm_test.sh starts its own daemons; none is enabled here). clang and its
# libFuzzer/sanitizer runtimes build the fuzz tree the test suite runs (docs/fuzzing.md).
set -eu
PKGS="build-essential cmake pkg-config git
      libsimbody-dev libeigen3-dev libfcl-dev coinor-libipopt-dev liburdfdom-dev libtinyxml-dev
      libtinyxml2-dev libcli11-dev nlohmann-json3-dev libcpptoml-dev
      libgtest-dev libgmock-dev libbenchmark-dev gnuplot-nox
      pybind11-dev python3-dev python3-pytest python3-numpy
      slurm-wlm munge
      clang libclang-rt-14-dev"
missing=""
for p in $PKGS; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing="$missing $p"
done
if [ -n "$missing" ]; then
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  # shellcheck disable=SC2086
  apt-get install -y -qq --no-install-recommends $missing
fi
echo "kneesim dependencies are installed."
