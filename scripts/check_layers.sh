#!/usr/bin/env bash
# The folder rules that include paths cannot enforce (tests/CMakeLists.txt probes the rest with the compiler):
# system GL/EGL/OSMesa headers and GL calls only in render/'s GL layer, Asio only in server/, client/ and cli/,
# OpenVDB, GDCM and libtiff only in brickstore/ (tests may use them to write files), and no include that climbs out
# of the folders by a relative path.
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

# GL-free parts of render/ (the sources of voxbrick_render_core, as render/CMakeLists.txt lists them).
core=$(awk '/^set\(core /{f=1} f{print} f && /\)/{exit}' render/CMakeLists.txt | sed 's/set(core//; s/)//')
coreFiles=()
for name in $core Compositing FrameRenderer RenderErrors SliceTables; do
  for f in render/$name.h render/$name.cpp; do [ -f "$f" ] && coreFiles+=("$f"); done
done
[ ${#coreFiles[@]} -ge 10 ] || { echo "check_layers: could not read the core list from render/CMakeLists.txt"; exit 1; }

mapfile -t outsideRender < <(sources brickstore mesh proto image server client cli bench)
mapfile -t notAsio < <(sources brickstore mesh proto image render bench)
mapfile -t notVdb < <(sources mesh proto image render server client cli bench)
mapfile -t everything < <(sources .)

forbid "GL, EGL or OSMesa headers outside render/'s GL layer" '#include <(GL|EGL|KHR)/' \
  "${outsideRender[@]}" "${coreFiles[@]}"
forbid "GL, EGL or OSMesa calls outside render/'s GL layer" '\b(gl|egl)[A-Z][A-Za-z0-9]*\s*\(|\bOSMesa[A-Z][A-Za-z]*\s*\(' \
  "${outsideRender[@]}" "${coreFiles[@]}"
forbid "Asio outside server/, client/ and cli/" '#include <boost/asio' "${notAsio[@]}"
forbid "OpenVDB outside brickstore/" '#include <(openvdb|nanovdb)/' "${notVdb[@]}"
forbid "GDCM or libtiff outside brickstore/" '#include <(gdcm[A-Za-z0-9]*\.h|tiff[a-z]*\.h)>' "${notVdb[@]}"
forbid "relative includes that leave a folder" '#include "\.\./' "${everything[@]}"

[ $status -eq 0 ] && echo "check_layers: every rule holds (${#everything[@]} files)"
exit $status
