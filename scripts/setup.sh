#!/usr/bin/env bash
# Installs every build and test dependency of imukit from Debian's archive (Debian 12).
# Idempotent: when everything is already installed it prints one line and changes nothing.
set -euo pipefail

packages=(
  # toolchain
  g++ cmake ninja-build pkg-config git
  clang llvm libclang-rt-14-dev clang-format     # fuzzers (libFuzzer), sanitizers, format check
  gcc-arm-none-eabi libnewlib-arm-none-eabi      # firmware_proto cross-compile check (Cortex-M4)
  # libraries
  libeigen3-dev libceres-dev nlohmann-json3-dev libcli11-dev libfmt-dev libzstd-dev zlib1g-dev
  libserialport-dev libhidapi-dev libusb-1.0-0-dev
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev umockdev libumockdev-dev
  python3 python3-numpy                          # independent check that numpy reads our .npy
  pybind11-dev python3-dev                       # the Python module (python/, docs/python.md)
  python3-scipy python3-pytest                   # dataset readers (loadmat), Python tests
  python3-torch python3-matplotlib               # imukit.har: HAR models, training, plots
  libopenblas0-pthread                           # torch's matrix products: 1.7x ATLAS (bench/har_step.py)
  gnuplot-nox                                    # characterize/calibrate --plot (SVG)
  zstd                                           # tests/cli/crash_test.py reads chunks itself
)
# node + npm run the MCAP project's own reader on our files (tests/capture/node); the machine
# image may already have a newer node than Debian's, which is fine.
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then packages+=(nodejs npm); fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} Debian packages already installed"
else
  sudo=""
  if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
  echo "setup: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  $sudo apt-get update -qq
  $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# npm packages pinned by tests/capture/node/package-lock.json.
root=$(cd "$(dirname "$0")/.." && pwd)
node_dir="$root/tests/capture/node"
if [ ! -d "$node_dir/node_modules/@mcap/core" ]; then
  echo "setup: npm ci in tests/capture/node"
  (cd "$node_dir" && npm ci --no-audit --no-fund --loglevel=error >/dev/null)
fi
echo "setup: done"
