#!/usr/bin/env bash
# The main job: set up, build, prepare the demo stores (a real MRI, a sparse synthetic field and a tetrahedral mesh),
# describe them, render a frame of each, headless, to demo/*.png, and have the server render the MRI and the mesh
# over TCP to demo/served.png and demo/served-mesh.png.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh voxbrick
mkdir -p demo
mri=/usr/share/mricron/templates/ch2better.nii.gz
./build/voxbrick prep "$mri" -o demo/mri.vbs --force
./build/voxbrick info demo/mri.vbs
./build/voxbrick prep synthetic:sparse,n=256 -o demo/sparse.vbs --force
./build/voxbrick info demo/sparse.vbs
./build/voxbrick render demo/mri.vbs -o demo/mri.png --scene config/scenes/mri-lateral.json --stats demo/mri-stats.json
./build/voxbrick render demo/sparse.vbs -o demo/sparse.png --tf sparse --orbit 30,20
./build/voxbrick prep synthetic-mesh:ball,n=32 -o demo/ball.vms --force
./build/voxbrick info demo/ball.vms
./build/voxbrick render demo/ball.vms -o demo/ball.png --tf hot --orbit 30,20

# A served frame: start the server on the demo stores, ask it for the MRI over TCP, save the PNG, stop the server.
rm -f demo/server.port
./build/voxbrick serve --config config/server.toml --port 0 --port-file demo/server.port > demo/server.log 2>&1 &
server=$!
trap 'kill $server 2>/dev/null || true' EXIT
for _ in $(seq 600); do [ -s demo/server.port ] && break; sleep 0.1; done
[ -s demo/server.port ] || { cat demo/server.log; echo "demo: the server did not start" >&2; exit 1; }
port=$(cat demo/server.port)
./build/voxbrick request "127.0.0.1:$port" --list
./build/voxbrick request "127.0.0.1:$port" --dataset mri.vbs --scene config/scenes/mri-lateral.json -o demo/served.png
./build/voxbrick request "127.0.0.1:$port" --dataset ball.vms --tf hot --orbit 30,20 -o demo/served-mesh.png
kill -TERM $server
wait $server
trap - EXIT
echo "demo: stores in demo/*.vbs and demo/ball.vms, frames in demo/{mri,sparse,ball}.png, served frames in" \
  "demo/served.png and demo/served-mesh.png"
