#!/usr/bin/env bash
# The folder rules that include paths cannot enforce (tests/CMakeLists.txt probes the rest with the compiler):
# system GL/EGL/OSMesa headers and GL calls only in render/gl/ (the folder alone decides: no build file is read),
# Asio and OpenSSL only in server/, client/ and cli/, OpenVDB only in brickstore/vdb/ and the OpenVDB module
# (brickstore/modules/openvdb/), GDCM only in the GDCM module (brickstore/modules/gdcm/), libtiff only in
# brickstore/ingest/tiff/ (tests may use them to write files) and libcurl only in brickstore/ingest/dicomweb/,
# MPI only in distributed/, cli/, bench/ and tests, nothing of bench/ (tools only, no library) included from outside
# it, and no include that climbs out of the folders by a relative path.
# Prints every violation as FILE:LINE: text and exits 1 if there is any. Run from the repository root.
set -uo pipefail
cd "$(dirname "$0")/.."

status=0
sources() { git ls-files --cached --others --exclude-standard -- "$@" | grep -E '\.(h|cpp)$'; }
# forbid DESCRIPTION PATTERN FILE...: reports the lines of FILEs matching the extended regular expression.
forbid() {
  local what=$1 pattern=$2
  shift 2
  [ $# -eq 0 ] && return
  local hits
  hits=$(grep -nE "$pattern" "$@" /dev/null | grep -vE '^[^:]+:[0-9]+:\s*//')
  if [ -n "$hits" ]; then
    echo "$what:"
    echo "$hits" | sed 's/^/  /'
    status=1
  fi
}

# The GL layer is render/gl/ and its subfolders; every other folder of render/ is GL-free.
mapfile -t notGl < <(sources common brickstore mesh proto image server client cli bench quality;
                     sources render | grep -v '^render/gl/')
# bench/bench_link_relay.cpp is a TCP relay (a slow link for the benchmarks), not part of the service.
mapfile -t notAsio < <(sources common brickstore mesh proto image render quality bench | grep -v '^bench/bench_link_relay.cpp$')
mapfile -t notVdb < <(sources common mesh proto image render quality server client cli bench;
                       sources brickstore | grep -vE '^brickstore/(vdb|modules/openvdb)/')
mapfile -t notGdcm < <(sources common brickstore mesh proto image render quality server client cli bench |
                       grep -v '^brickstore/modules/gdcm/')
mapfile -t notTiff < <(sources common brickstore mesh proto image render quality server client cli bench |
                       grep -v '^brickstore/ingest/tiff/')
mapfile -t notCurl < <(sources common brickstore mesh proto image render quality server client cli bench |
                       grep -v '^brickstore/ingest/dicomweb/')
mapfile -t notMpi < <(sources common brickstore mesh proto image render quality server client)
mapfile -t everything < <(sources .)
mapfile -t notBench < <(sources . | grep -v '^bench/')

forbid "GL, EGL or OSMesa headers outside render/gl/" '#include <(GL|EGL|KHR)/' "${notGl[@]}"
forbid "GL, EGL or OSMesa calls outside render/gl/" '\b(gl|egl)[A-Z][A-Za-z0-9]*\s*\(|\bOSMesa[A-Z][A-Za-z]*\s*\(' \
  "${notGl[@]}"
forbid "Asio outside server/, client/, cli/ and the benchmarks' link relay" '#include <boost/asio' "${notAsio[@]}"
forbid "OpenSSL outside server/, client/ and cli/" '#include <openssl/' "${notAsio[@]}"
forbid "OpenVDB outside brickstore/vdb/ and brickstore/modules/openvdb/" '#include <(openvdb|nanovdb)/' "${notVdb[@]}"
forbid "GDCM outside brickstore/modules/gdcm/" '#include <gdcm[A-Za-z0-9]*\.h>' "${notGdcm[@]}"
forbid "libtiff outside brickstore/ingest/tiff/" '#include <tiff[a-z]*\.h>' "${notTiff[@]}"
forbid "libcurl outside brickstore/ingest/dicomweb/" '#include <curl/' "${notCurl[@]}"
forbid "MPI outside distributed/, cli/, bench/ and tests" '#include <mpi\.h>' "${notMpi[@]}"
forbid "bench/ included outside bench/ (its tools are programs, not a library)" '#include "bench/' "${notBench[@]}"
forbid "relative includes that leave a folder" '#include "\.\./' "${everything[@]}"

[ $status -eq 0 ] && echo "check_layers: every rule holds (${#everything[@]} files)"
exit $status
