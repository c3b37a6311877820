#!/usr/bin/env bash
# Installs the build and test dependencies from Debian 12 packages (as root),
# then the web app's npm packages (web/package-lock.json, `npm ci`).
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
  libyaml-cpp-dev               # NTRT YAML structures (import, export)
  libmujoco-dev                 # MuJoCo: the suite simulates the MJCF export
  gnuplot-nox                   # benchmark plots
  clang libclang-rt-14-dev lld  # sanitizer and fuzzer builds (lld links them)
  python3-jsonschema            # the JSON Schema test of docs/schemas/
  libcpp-httplib-dev            # HTTP server of `tensegrity serve`
  chromium                      # the web app's browser test (playwright-core drives it)
  # The Python package, built for and tested with Debian's /usr/bin/python3:
  python3-dev pybind11-dev python3-pybind11 python3-numpy
  python3-pandas python3-distributed python3-pytest python3-matplotlib
)
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"

# `import tensegrity` for /usr/bin/python3 without PYTHONPATH: a .pth file in
# its site folder names this checkout's build/python (where the build puts the
# module; a missing folder is skipped by Python until the first build).
# TENSEGRITY_NO_PTH=1 leaves the interpreter alone.
install_python_path() {
  [ "${TENSEGRITY_NO_PTH:-0}" != 1 ] && [ -x /usr/bin/python3 ] || return 0
  local site pth build_python
  site=$(/usr/bin/python3 -c 'import site; print(site.getsitepackages()[0])')
  pth=$site/tensegrity-build.pth
  build_python=$(cd "$(dirname "$0")/.." && pwd)/build/python
  [ -f "$pth" ] && [ "$(cat "$pth")" = "$build_python" ] && return 0
  $SUDO mkdir -p "$site" && echo "$build_python" | $SUDO tee "$pth" >/dev/null &&
    echo "setup: /usr/bin/python3 imports tensegrity from $build_python ($pth)"
}

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
# Node and npm: Debian's packages unless some node is already installed.
command -v node >/dev/null || missing+=(nodejs)
command -v npm >/dev/null || missing+=(npm)
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all Debian packages present"
else
  echo "setup: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
install_python_path

# three.js (served to the app) and playwright-core (the browser test), as pinned
# in the lockfile; npm ci again only when the lockfile changed.
web="$(cd "$(dirname "$0")/../web" && pwd)"
if ! cmp -s "$web/package-lock.json" "$web/node_modules/.package-lock.json.installed" 2>/dev/null; then
  echo "setup: npm ci in $web"
  (cd "$web" && npm ci --no-audit --no-fund)
  cp "$web/package-lock.json" "$web/node_modules/.package-lock.json.installed"
else
  echo "setup: web/node_modules up to date"
fi
