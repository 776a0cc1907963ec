#!/usr/bin/env bash
# Installs every build and test dependency of voxbrick from Debian 12 packages. Idempotent; run as root.
set -euo pipefail

PACKAGES=(
  build-essential cmake ninja-build pkg-config git clang lld
  libopenvdb-dev libtbb-dev libblosc-dev libzstd-dev zlib1g-dev
  libboost-dev libboost-system-dev libboost-iostreams-dev
  libglm-dev libgl-dev
  libegl-dev libgl-dev libegl-mesa0 libgl1-mesa-dri libosmesa6-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  nlohmann-json3-dev libcli11-dev libspdlog-dev libfmt-dev libtomlplusplus-dev libpng-dev libjpeg62-turbo-dev
  libvpx-dev libyuv-dev libwebp-dev
  libssl-dev openssl
  libgdcm-dev libtiff-dev zstd libcurl4-openssl-dev
  mricron-data
  python3 python3-numpy python3-zarr python3-numcodecs python3-pydicom
  python3-pil python3-zstandard python3-pytest jupyter-notebook jupyter-nbconvert python3-nbconvert python3-ipykernel
  openmpi-bin libopenmpi-dev
  chromium nodejs fonts-dejavu-core
  prometheus
  orthanc orthanc-dicomweb
)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

# The browser tests' packages come from npm (tests/browser/package-lock.json); npm ships with some builds of nodejs and
# is a package of its own in Debian's.
command -v npm > /dev/null 2>&1 || missing+=(npm)

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#PACKAGES[@]} packages already installed"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive

# prometheus and orthanc: tests/prometheus and tests/dicomweb need their binaries (each test starts its own on free
# ports), not their Debian services. Where nothing forbids starting services at install (container images have a
# policy-rc.d that does), one is in place for the install, so that a service that cannot start (no init system, port
# 9090 or 8042 taken) does not fail it, and none is left running; a systemd service the install enabled is stopped and
# disabled again.
services=()
for s in prometheus orthanc; do
  [[ " ${missing[*]} " == *" $s "* ]] && services+=("$s")
done
policy=/usr/sbin/policy-rc.d
addedPolicy=0
if [ ${#services[@]} -gt 0 ] && [ ! -e "$policy" ]; then
  printf '#!/bin/sh\n# scripts/setup.sh: no service starts while it installs packages\nexit 101\n' |
    $SUDO tee "$policy" > /dev/null
  $SUDO chmod 755 "$policy"
  addedPolicy=1
fi
removePolicy() { if [ $addedPolicy -eq 1 ]; then $SUDO rm -f "$policy"; fi; }
trap removePolicy EXIT

$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
if [ ${#services[@]} -gt 0 ] && [ -d /run/systemd/system ]; then
  for s in "${services[@]}"; do $SUDO systemctl disable --now "$s.service" > /dev/null 2>&1 || true; done
fi
