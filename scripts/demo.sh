#!/usr/bin/env bash
# The main job: set up, build, prepare the demo datasets (a real MRI and a sparse synthetic field), describe them.
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
echo "demo: stores in demo/mri.vbs and demo/sparse.vbs"
