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
  libeigen3-dev libceres-dev nlohmann-json3-dev libcli11-dev libfmt-dev libzstd-dev
  libserialport-dev libhidapi-dev libusb-1.0-0-dev
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev umockdev libumockdev-dev
  python3 python3-numpy                          # independent check that numpy reads our .npy
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages already installed"
  exit 0
fi

sudo=""
if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "setup: done"
