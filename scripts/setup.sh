#!/usr/bin/env bash
# Installs the build and test dependencies from Debian 12 packages (as root).
# Does nothing when everything is already there.
set -euo pipefail
packages=(
  build-essential cmake pkg-config git
  libeigen3-dev                 # Eigen 3.4
  coinor-libipopt-dev           # Ipopt 3.11 with MUMPS (pkg-config: ipopt)
  libnlopt-cxx-dev              # NLopt with the C++ API (CMake: NLopt::nlopt_cxx)
  libopenblas-dev               # fast BLAS/LAPACK for MUMPS
  googletest libgtest-dev libgmock-dev
  libbenchmark-dev              # Google Benchmark
  nlohmann-json3-dev libcli11-dev
  libcairo2-dev                 # drawing (render command)
  gnuplot-nox                   # benchmark plots
  clang libclang-rt-14-dev      # sanitizer and fuzzer builds
  python3-numpy                 # tests/reference/compute_optima.py (reference optima)
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all dependencies present"
  exit 0
fi
echo "setup: installing ${missing[*]}"
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
