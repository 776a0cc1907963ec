#!/usr/bin/env bash
# A local PACS to try `voxbrick prep dicomweb://...` on: Debian's Orthanc with its DICOMweb plugin (scripts/setup.sh
# installs both), listening on 127.0.0.1 only, with a user whose password is made here and kept in DIR/auth, and
# the demo series uploaded: the demo MRI (mricron's ch2better.nii.gz) as an MR series of 316 slices
# (scripts/demo_series.py), and the small CT series of pydicom's test files that README.md preps from a folder.
# Prints each series' dicomweb:// URL and a prep command. No secret is put on a command line (curl reads DIR/netrc).
# --ct N adds a synthetic CT of N slices of 512x512 (demo_series.py --ct, N/2 MB, written to DIR/ct-N): a series of
# a clinical CT's size for benchmarks (bench/results/dicomweb/).
#
#   bash scripts/orthanc_demo.sh [--port 8042] [--dir demo/orthanc] [--ct 512]   # start it, upload, list the series
#   bash scripts/orthanc_demo.sh stop [--dir demo/orthanc]             # stop it (its storage stays in DIR)
set -euo pipefail
cd "$(dirname "$0")/.."

port=8042
dir=demo/orthanc
action=start
ct_slices=0
while [ $# -gt 0 ]; do
  case "$1" in
    stop) action=stop ;;
    --port) port=$2; shift ;;
    --dir) dir=$2; shift ;;
    --ct) ct_slices=$2; shift ;;
    *) echo "usage: orthanc_demo.sh [stop] [--port PORT] [--dir DIR] [--ct SLICES]" >&2; exit 2 ;;
  esac
  shift
done
mkdir -p "$dir"
dir=$(cd "$dir" && pwd)

stopServer() {
  if [ -f "$dir/orthanc.pid" ] && kill -0 "$(cat "$dir/orthanc.pid")" 2> /dev/null; then
    local pid
    pid=$(cat "$dir/orthanc.pid")
    kill "$pid"
    for _ in $(seq 1 100); do kill -0 "$pid" 2> /dev/null || break; sleep 0.1; done  # its database lock goes with it
    echo "orthanc_demo: stopped Orthanc ($pid)"
  fi
  rm -f "$dir/orthanc.pid"
}
if [ "$action" = stop ]; then
  stopServer
  exit 0
fi

orthanc=$(command -v Orthanc || echo /usr/sbin/Orthanc)
plugin=$(dpkg -L orthanc-dicomweb 2> /dev/null | grep -m1 '/libOrthancDicomWeb\.so$' || true)
if [ ! -x "$orthanc" ] || [ -z "$plugin" ]; then
  echo "orthanc_demo: Orthanc or its DICOMweb plugin is missing: run scripts/setup.sh (orthanc, orthanc-dicomweb)" >&2
  exit 1
fi
mri=/usr/share/mricron/templates/ch2better.nii.gz
ct=/usr/lib/python3/dist-packages/pydicom/data/test_files/dicomdirtests/98892001/CT5N
for f in "$mri" "$ct"; do
  [ -e "$f" ] || { echo "orthanc_demo: $f missing: run scripts/setup.sh (mricron-data, python3-pydicom)" >&2; exit 1; }
done
if [ ! -s "$dir/mri/IM0316.dcm" ]; then
  echo "orthanc_demo: writing the demo MRI as a DICOM series in $dir/mri"
  /usr/bin/python3 scripts/demo_series.py "$mri" "$dir/mri" > /dev/null
fi
series_dirs=("$dir/mri" "$ct")
if [ "$ct_slices" != 0 ]; then
  if ! [[ "$ct_slices" =~ ^[1-9][0-9]{0,3}$ ]]; then
    echo "orthanc_demo: --ct wants a number of slices (1 to 9999)" >&2
    exit 2
  fi
  if [ ! -s "$dir/ct-$ct_slices/$(printf 'IM%04d.dcm' "$ct_slices")" ]; then
    echo "orthanc_demo: writing a synthetic CT of $ct_slices slices in $dir/ct-$ct_slices"
    /usr/bin/python3 scripts/demo_series.py --ct "$ct_slices" "$dir/ct-$ct_slices" > /dev/null
  fi
  series_dirs+=("$dir/ct-$ct_slices")
fi

stopServer
# The password: made once, kept (mode 600) in DIR/auth for voxbrick and DIR/netrc for curl.
if [ ! -s "$dir/password" ]; then
  (umask 077; head -c 18 /dev/urandom | base64 | tr -d '/+=' > "$dir/password")
fi
password=$(cat "$dir/password")
(umask 077
 printf 'basic demo:%s\n' "$password" > "$dir/auth"
 printf 'machine 127.0.0.1 login demo password %s\n' "$password" > "$dir/netrc"
 cat > "$dir/orthanc.json" << EOF
{
  "Name": "voxbrick-demo",
  "StorageDirectory": "$dir/storage",
  "IndexDirectory": "$dir/storage",
  "HttpPort": $port,
  "DicomServerEnabled": false,
  "RemoteAccessAllowed": false,
  "AuthenticationEnabled": true,
  "RegisteredUsers": {"demo": "$password"},
  "Plugins": ["$plugin"],
  "DicomWeb": {"Enable": true, "Root": "/dicom-web/", "EnableWado": false}
}
EOF
)
mkdir -p "$dir/storage"
nohup "$orthanc" "$dir/orthanc.json" > "$dir/orthanc.log" 2>&1 &
echo $! > "$dir/orthanc.pid"
base=http://127.0.0.1:$port
for _ in $(seq 1 100); do
  curl -s -o /dev/null --netrc-file "$dir/netrc" "$base/system" && break
  kill -0 "$(cat "$dir/orthanc.pid")" 2> /dev/null || { cat "$dir/orthanc.log" >&2; exit 1; }
  sleep 0.1
done
curl -sf -o /dev/null --netrc-file "$dir/netrc" "$base/system" || { echo "orthanc_demo: Orthanc did not start" >&2; exit 1; }

count=0
while IFS= read -r -d '' f; do
  curl -sf -o /dev/null --netrc-file "$dir/netrc" -X POST --data-binary "@$f" "$base/instances"
  count=$((count + 1))
done < <(find "${series_dirs[@]}" -type f -print0)
echo "orthanc_demo: Orthanc on $base (log $dir/orthanc.log; stop: bash scripts/orthanc_demo.sh stop --dir $dir)," \
     "$count files uploaded"
echo "orthanc_demo: the series, each a dicomweb:// URL for voxbrick prep --auth-file $dir/auth:"
curl -sf --netrc-file "$dir/netrc" -H 'Accept: application/dicom+json' "$base/dicom-web/series" |
  python3 -c '
import json, sys
for s in json.load(sys.stdin):
    value = lambda tag: (s.get(tag, {}).get("Value") or ["-"])[0]
    print("  %-3s %4s instances  dicomweb://127.0.0.1:%s/dicom-web/studies/%s/series/%s" % (
        value("00080060"), value("00201209"), sys.argv[1], value("0020000D"), value("0020000E")))
' "$port" | tee "$dir/series.txt"
echo "orthanc_demo: the MRI, fetched, prepped and drawn:"
echo "  ./build/voxbrick prep $(awk '$1 == "MR" {print $4}' "$dir/series.txt") --auth-file $dir/auth -o data/pacs-mri.vbs"
echo "  ./build/voxbrick render data/pacs-mri.vbs --tf mri --view left -o pacs-mri.png"
