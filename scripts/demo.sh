#!/usr/bin/env bash
# The main job: set up, build, prepare the demo stores (a real MRI and a sparse synthetic field), describe them,
# and render a frame of each, headless, to demo/*.png.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh
mkdir -p demo
mri=/usr/share/mricron/templates/ch2better.nii.gz
./build/voxbrick prep "$mri" -o demo/mri.vbs --force
./build/voxbrick info demo/mri.vbs
./build/voxbrick prep synthetic:sparse,n=256 -o demo/sparse.vbs --force
./build/voxbrick info demo/sparse.vbs
./build/voxbrick render demo/mri.vbs -o demo/mri.png --scene config/scenes/mri-lateral.json --stats demo/mri-stats.json
./build/voxbrick render demo/sparse.vbs -o demo/sparse.png --tf sparse --orbit 30,20,2.5
echo "demo: stores in demo/*.vbs, frames in demo/mri.png and demo/sparse.png"
