#!/usr/bin/env python3
"""Quality by target, measured: each bench dataset is calibrated (`voxbrick bench --calibrate`), then frames asked
for with `--quality psnr:X` are judged against the reference renderer, and frames asked for with `--quality ms:N` are
timed (warm, the median of --repeats frames), at views that are not the calibration's as well as one that is.
Writes bench/results/quality/quality.csv and quality.md. Run through bench/run_quality.sh."""
import argparse
import csv
import json
import os
import statistics
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# name, prep input, transfer function (each dataset's default in the committed sweep)
DATASETS = [
    ("ml", "synthetic:marschner-lobb,n=128", "hot"),
    ("sparse", "synthetic:sparse,n=256", "sparse"),
    ("mri", "/usr/share/mricron/templates/ch2better.nii.gz", "mri"),
]


def run(args, **kw):
    result = subprocess.run(args, capture_output=True, text=True, **kw)
    if result.returncode != 0:
        sys.exit(f"quality_bench: {' '.join(args)} failed ({result.returncode}):\n{result.stdout}{result.stderr}")
    return result


def psnr(a, b):
    """PSNR of two PNGs' RGB (8-bit), through `voxbrick compare`."""
    out = run([BIN, "compare", a, b]).stdout  # "compare: WxH  rmse R  psnr P dB  max_abs M"
    words = out.split()
    if "psnr" not in words:
        sys.exit(f"quality_bench: cannot read a PSNR from: {out}")
    return float(words[words.index("psnr") + 1])


def main():
    global BIN
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--work", default=os.path.join(ROOT, "bench/work/quality"))
    p.add_argument("--out", default=os.path.join(ROOT, "bench/results/quality"))
    p.add_argument("--datasets", default="ml,sparse,mri")
    p.add_argument("--size", default="512x512", help="size of the judged and timed frames")
    p.add_argument("--calibration-size", type=int, default=256)
    p.add_argument("--views", default="default;orbit=0,20,2.2;orbit=75,35,3;orbit=200,-30,3",
                   help="';'-separated: 'default' (the default camera) or orbit=AZ,EL,DIST")
    p.add_argument("--psnr", default="30,40,50")
    p.add_argument("--ms", default="100,200,500,1000")
    p.add_argument("--repeats", type=int, default=3)
    a = p.parse_args()
    BIN = os.path.join(ROOT, "build/voxbrick")
    os.makedirs(a.work, exist_ok=True)
    os.makedirs(a.out, exist_ok=True)
    rows = []
    for name, source, tf in DATASETS:
        if name not in a.datasets.split(","):
            continue
        store = os.path.join(a.work, name + ".vbs")
        if not os.path.exists(os.path.join(store, "store.json")):
            run([BIN, "prep", source, "-o", store, "--no-vdb", "-q"])
        if not os.path.exists(os.path.join(store, "quality.json")):
            t = time.time()
            run([BIN, "bench", "--calibrate", store, "--tf", tf, "--size", str(a.calibration_size), "-q",
                 "--work", os.path.join(a.work, "calibration")])
            print(f"{name}: calibrated in {time.time() - t:.0f} s", flush=True)
        for view in a.views.split(";"):
            camera = [] if view == "default" else ["--orbit", view.split("=", 1)[1]]
            common = [store, "--tf", tf, "--size", a.size, "-q"] + camera
            ref = os.path.join(a.work, f"{name}-{view.replace(',', '_').replace('=', '')}-{a.size}-ref.png")
            if not os.path.exists(ref):
                run([BIN, "render", *common, "--backend", "reference", "-o", ref])
            for target in [f"psnr:{x}" for x in a.psnr.split(",")] + [f"ms:{x}" for x in a.ms.split(",")]:
                png, stats = os.path.join(a.work, "q.png"), os.path.join(a.work, "q.json")
                times = []
                for _ in range(a.repeats if target.startswith("ms:") else 1):
                    run([BIN, "render", *common, "--quality", target, "--warm-up", "2", "-o", png, "--stats", stats])
                    s = json.load(open(stats))
                    times.append(s["ms"]["total"])
                q = s["quality"]
                row = {"dataset": name, "tf": tf, "view": view, "size": a.size, "target": target,
                       "setting": q["setting"], "met_in_table": q["met"],
                       "expected_psnr": round(q["expected_psnr"], 2), "expected_ms": round(q["expected_ms"], 1),
                       "psnr": round(psnr(png, ref), 2), "ms_median": round(statistics.median(times), 1)}
                goal = float(target.split(":")[1])
                row["meets"] = row["psnr"] >= goal if target.startswith("psnr:") else row["ms_median"] <= goal
                rows.append(row)
                print(", ".join(f"{k} {v}" for k, v in row.items()), flush=True)
    fields = list(rows[0].keys())
    with open(os.path.join(a.out, "quality.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)
    with open(os.path.join(a.out, "quality.md"), "w") as f:
        f.write("# Quality by target, measured\n\n")
        f.write("`bash bench/run_quality.sh`: "
                f"each dataset calibrated at {a.calibration_size}² (`voxbrick bench --calibrate`, 6 orbit views at "
                f"azimuth 0, 60, ..., 300, elevations 20, -30, 55 in turn, 2.2 radii; a PSNR target needs 1 dB more "
                f"in the table, a time target 10 % less), then judged at {a.size} against the reference "
                "(`render --backend reference`, step 0.125) at the views below; times are warm frames (`--warm-up 2`), "
                f"the median of {a.repeats}. `meets`: the frame reached the target (PSNR at or above it, time at or "
                "under it); `met_in_table`: the table had a setting for it (else the closest was used).\n\n")
        f.write("| " + " | ".join(fields) + " |\n|" + "---|" * len(fields) + "\n")
        for r in rows:
            f.write("| " + " | ".join(str(r[k]) for k in fields) + " |\n")
        met = sum(1 for r in rows if r["meets"])
        f.write(f"\n{met} of {len(rows)} frames met their target.\n")


if __name__ == "__main__":
    main()
