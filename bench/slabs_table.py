#!/usr/bin/env python3
"""The texture-slab table in the shape of Yalim 2005's (chapter 5), from sweep.csv files of `voxbrick bench`.

For each dataset and transfer function, at the given steps: slicing (one blended sample per fragment), slabs without
silhouette maps, slabs with the early-ray-termination silhouette map (and with sub-blocks), pre-integration, and the
frame ray caster (column `raycast`, absent from sweeps made before it) likewise: median frame time, fragments started
and samples taken, the share of fragments and samples processed against the same slab size (or the ray caster)
without termination, the speed-up over slicing and the worst-view PSNR against the reference.

    python3 bench/slabs_table.py bench/results/sweep/slabs/sweep.csv [--steps 0.75,1] > table.md
"""
import argparse
import csv
import sys


def raycast(row):
    return row.get("raycast", "0") == "1"


def label(row):
    """As sweep.md's slab table names the settings (bench::marchingLabel): "slicing", "slab 32, ert 0.999",
    "raycast, ert 0.999, sub-block 8"."""
    slab = int(row["slab"])
    if slab == 0 and not raycast(row):
        return "slicing"
    text = "raycast" if raycast(row) else "slab whole brick" if slab >= 4096 else f"slab {slab}"
    if float(row["ert"]) > 0:
        text += f", ert {float(row['ert']):g}"
    if row["pre_integration"] == "1":
        text += ", pre-int"
    if row.get("sub_block", "0") not in ("", "0"):
        text += f", sub-block {row['sub_block']}"
    if float(row.get("lod") or 0) > 0:
        text += f", lod {float(row['lod']):g}"
    return text


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("csv", nargs="+")
    parser.add_argument("--steps", default="0.75,1", help="steps to tabulate, comma-separated")
    args = parser.parse_args()
    steps = [float(s) for s in args.steps.split(",")]
    rows = []
    for path in args.csv:
        with open(path, newline="") as f:
            for row in csv.DictReader(f):
                if row["shading"] == "0" and row["brick"] == "32" and row["skip"] == "1" and row["slicer"] == "vertex":
                    row["source"] = path
                    rows.append(row)
    out = sys.stdout
    for source in dict.fromkeys(r["source"] for r in rows):
        size = next(r["size"] for r in rows if r["source"] == source)
        out.write(f"### `{source}` ({size}×{size})\n\n")
        groups = dict.fromkeys((r["dataset"], r["transfer_function"]) for r in rows if r["source"] == source)
        for dataset, tf in groups:
            for step in steps:
                sel = [r for r in rows if r["source"] == source and r["dataset"] == dataset
                       and r["transfer_function"] == tf and float(r["step"]) == step]
                slicing = next((r for r in sel if label(r) == "slicing"), None)
                if slicing is None or len(sel) < 2:
                    continue
                out.write(f"**{dataset}, {tf}, step {step:g}**\n\n")
                out.write("| setting | median ms | speed-up | fragments (M) | samples (M) | share of fragments | "
                          "share of samples | worst view dB | pooled dB |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|\n")
                base_ms = float(slicing["median_ms"])
                # Slicing, the slab sizes, then the ray caster.
                for r in sorted(sel, key=lambda r: (raycast(r), int(r["slab"]) != 0, int(r["slab"]), float(r["ert"]),
                                                     r.get("sub_block", "0"), r["pre_integration"])):
                    # Shares against the same slab size (or the ray caster) without termination (and without
                    # sub-blocks, pre-integration).
                    plain = next((p for p in sel if p["slab"] == r["slab"] and raycast(p) == raycast(r)
                                  and float(p["ert"]) == 0 and p.get("sub_block", "0") in ("", "0")
                                  and p["pre_integration"] == "0"), None)
                    frag, samp = float(r["fragments_median"]), float(r["samples_median"])
                    share_f = f"{100 * frag / float(plain['fragments_median']):.0f} %" if plain and plain is not r else "—"
                    share_s = f"{100 * samp / float(plain['samples_median']):.0f} %" if plain and plain is not r else "—"
                    out.write(f"| {label(r)} | {float(r['median_ms']):.1f} | {base_ms / float(r['median_ms']):.2f}× | "
                              f"{frag / 1e6:.2f} | {samp / 1e6:.2f} | {share_f} | {share_s} | "
                              f"{float(r['psnr_worst_db']):.1f} | {float(r['psnr_pooled_db']):.1f} |\n")
                out.write("\n")


if __name__ == "__main__":
    main()
