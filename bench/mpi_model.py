#!/usr/bin/env python3
"""The distributed mode's report (bench/results/mpi/mpi.md) from run_mpi.sh's figures: the compositor's measured ms and
bytes beside the baseline's (binary swap, run interleaved on the same partial frames), radix-k's factorisations, each
rank's host cache against its budget, and two cost models fitted to the compositing figures,
    T(N, P) = alpha * steps(N) + gamma * P * (1 - 1/N) * max(1, N / cores)      (a cost per frame pixel)
    T(N, P) = alpha * steps(N) + gamma_h * H(N, P) * max(1, N / cores)          (a cost per pixel handled)
(steps: the exchanges a rank takes part in; P the frame's pixels; H the most pixels one rank handled, counted by the
compositor), projected to 8, 64 and 512 ranks on 10 and 100 Gb/s links, H and the bytes of 8 and 64 ranks counted
at a smaller frame and scaled by its pixels. Needs numpy (Debian's /usr/bin/python3)."""
import argparse
import csv
import datetime
import json
import math
import sys

import numpy as np

NEW, WHOLE, OLD = "radix-k", "radix-k-whole", "binary-swap"


RADIX_FACTORS = {}  # N -> [k, ...]: distributed::radixFactors, printed by bench_composite --print-factors


def radix_factors(n):
    if n not in RADIX_FACTORS:
        sys.exit(f"mpi_model: radixFactors({n}) was not given (--radix-factors)")
    return RADIX_FACTORS[n]


def steps(impl, n):
    if n == 1:
        return 0
    if impl in (NEW, WHOLE):
        return len(radix_factors(n)) + 1  # the rounds and the gather
    power = 1 << (n.bit_length() - 1)
    return (1 if n != power else 0) + int(math.log2(power)) + 1  # the fold, the swap rounds and the gather


def fit(rows, impl, column, cores, handled=False):
    """alpha and gamma (a cost per frame pixel, or per pixel handled) by least squares, and the median error."""
    fitted = [r for r in rows if r["impl"] == impl and int(r["ranks"]) >= 2]
    if not fitted:
        return None
    work = (lambda r: float(r["handled_max_rank"])) if handled else \
        (lambda r: int(r["size"]) ** 2 * (1 - 1 / int(r["ranks"])))
    X = np.array([[steps(impl, int(r["ranks"])), work(r) * max(1, int(r["ranks"]) / cores)] for r in fitted])
    y = np.array([float(r[column]) / 1000 for r in fitted])
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    coef = np.maximum(coef, [1e-7, 1e-12])  # a negative share is noise: floored
    rel = float(np.median(np.abs(X @ coef - y) / y))
    return coef[0], coef[1], rel


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--csv", required=True)
    ap.add_argument("--factors", required=True)
    ap.add_argument("--counts", required=True, help="8 and 64 ranks' pixels handled and bytes (one repeat each)")
    ap.add_argument("--budget", required=True)
    ap.add_argument("--volume-bytes", type=int, required=True)
    ap.add_argument("--smoke", type=int, default=0)
    ap.add_argument("--cores", type=int, default=1, help="cores the ranks shared while measured")
    ap.add_argument("--command", default="bash bench/run_mpi.sh")
    ap.add_argument("--machine", default="2-core VM, llvmpipe, no GPU")
    ap.add_argument("--load", default="", help="the load average while measured")
    ap.add_argument("--radix-factors", required=True, help="radixFactors as 'N:KxK ...' (bench_composite)")
    a = ap.parse_args()
    for item in a.radix_factors.split():
        n, text = item.split(":")
        RADIX_FACTORS[int(n)] = [int(k) for k in text.split("x")] if text != "-" else []
    rows = list(csv.DictReader(open(a.csv)))
    factor_rows = list(csv.DictReader(open(a.factors)))
    count_rows = list(csv.DictReader(open(a.counts)))
    by_key = {}
    for r in rows:
        by_key.setdefault((int(r["ranks"]), int(r["size"]), r["encoding"]), {})[r["impl"]] = r
    for key, impls in by_key.items():
        digests = {r["inputs"] for r in impls.values()}
        if len(digests) > 1:
            sys.exit(f"mpi_model: the implementations composited different inputs at {key}: {digests}")
    have_old = any(r["impl"] == OLD for r in rows)
    out = ["# The distributed mode measured\n"]
    if a.smoke:
        out.append("**SMOKE RUN** (small sizes, few repeats): it proves the script works; the figures are not the "
                   "ones to quote. Rerun `bash bench/run_mpi.sh --baseline-build …` on a quiet machine.\n")
    out.append(f"Measured {datetime.date.today().isoformat()} on a {a.machine}, every rank on it (oversubscribed "
               f"past {a.cores}: what compositing costs, not a speed-up){'; load average ' + a.load if a.load else ''}."
               f" Command: `{a.command}`.\n")
    out.append("Each rank's partial frame is its part of a volume split as the partition splits one (a k-d tree of "
               "one box per rank, balanced by volume), drawn by `bench_composite` (soft blobs in a skin, ray-marched "
               "at 256² and scaled up): the volume covers most of the frame, each part a share of it. The "
               "compositors get the same frames (the digest of the inputs is checked). ms: the median over the "
               "repeats of the slowest rank's time from a barrier to the finished 8-bit frame on rank 0 (radix-k: "
               "`compositeFinished`, each rank finishing its own region; binary swap: `composite`, then "
               "`finishPartial` and `toImage8` on rank 0, as `RankRenderer` did); 'composite only' is the "
               "baseline's `composite` call alone, its own figure. Radix-k runs twice on the same frames: each rank "
               "reading only its part's footprint (the box's projection on the screen, as the server does: "
               "`CompositeOptions::footprint`), and reading its whole frame (the compositor before footprints). "
               "Active: the share of a rank's frame pixels with anything in them (mean over ranks), and of the "
               "frame's pixels active on some rank; footprint: the share of a rank's frame in its footprint (mean). "
               "Handled: the most pixels one rank handled (`CompositeStats::pixelsHandled`: its footprint read, the "
               "active pixels it joined, its final region), over the frame's pixels. Bytes: message bytes sent by "
               "all ranks. Half floats.\n")
    out.append("| ranks | size | active (rank / frame) | footprint | binary swap, to 8-bit (ms) "
               "| binary swap, composite only (ms) | radix-k, whole frames (ms) | radix-k, footprints (ms) | faster "
               "| handled, whole / footprints | bytes, binary swap | bytes, radix-k |")
    out.append("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for (n, size, _), impls in sorted(by_key.items()):
        new, whole, old = impls.get(NEW), impls.get(WHOLE), impls.get(OLD)
        if not new:
            continue
        ms = lambda r, column: f"{float(r[column]):.2f}" if r else "–"
        sent = lambda r: f"{int(float(r['bytes_total'])):,}" if r else "–"
        faster = f"{float(old['ms_median']) / float(new['ms_median']):.1f}×" if old else "–"
        active = f"{float(new['active_share']) * 100:.0f} % / {float(new['union_share']) * 100:.0f} %"
        share = lambda r: f"{float(r['handled_max_rank']) / size ** 2:.2f}" if r else "–"
        out.append(f"| {n} | {size}² | {active} | {float(new['footprint_share']) * 100:.0f} % | "
                   f"{ms(old, 'ms_median')} | {ms(old, 'ms_composite_median')} | {ms(whole, 'ms_median')} | "
                   f"{ms(new, 'ms_median')} | {faster} | {share(whole)} / {share(new)} | {sent(old)} | {sent(new)} |")
    # Factorisations.
    out.append("\n## Radix-k's factorisations\n")
    out.append("Every ordered factorisation of the rank count (k per round; binary swap is 2 throughout), the same "
               "frames, ms as above; **bold** the fastest at each size, and the factorisation `radixFactors` uses "
               "(its table, recorded from these runs).\n")
    out.append("| ranks | size | " + "factorisation: ms (median) | " + "used |")
    out.append("| --- | --- | --- | --- |")
    groups = {}
    for r in factor_rows:
        groups.setdefault((int(r["ranks"]), int(r["size"])), []).append(r)
    for (n, size), group in sorted(groups.items()):
        best = min(group, key=lambda r: float(r["ms_median"]))
        cells = []
        for r in group:
            text = f"{r['factors']}: {float(r['ms_median']):.1f}"
            cells.append(f"**{text}**" if r is best else text)
        used = "x".join(str(k) for k in radix_factors(n))
        out.append(f"| {n} | {size}² | {', '.join(cells)} | {used} |")
    # Host budgets.
    stats = json.load(open(a.budget))
    d = stats["distributed"]
    out.append("\n## A volume larger than one rank's host budget\n")
    budget = d["per_rank"][0]["host_cache_budget_bytes"]
    out.append(f"A {a.volume_bytes / 2**20:.0f} MiB f32 volume ({a.volume_bytes / max(budget, 1):.1f}x one rank's "
               f"host budget of {budget / 2**20:.1f} MiB) drawn by {d['ranks']} ranks at 512² "
               f"(`render --mpi --host-cache`): each rank's peak host cache.\n")
    out.append("| rank | bricks drawn | host cache peak | budget | within | drawing ms | compositing ms | bytes sent |")
    out.append("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for p in d["per_rank"]:
        ok = "yes" if p["host_cache_peak_bytes"] <= p["host_cache_budget_bytes"] else "**NO**"
        out.append(f"| {p['rank']} | {p['bricks_drawn']} | {p['host_cache_peak_bytes'] / 2**20:.2f} MiB | "
                   f"{p['host_cache_budget_bytes'] / 2**20:.2f} MiB | {ok} | {p['drawing_ms']:.1f} | "
                   f"{p['compositing_ms']:.1f} | {p['bytes_sent']:,} |")
    # The fits.
    new_fit = fit(rows, NEW, "ms_median", a.cores)
    whole_fit = fit(rows, WHOLE, "ms_median", a.cores)
    old_fit = fit(rows, OLD, "ms_composite_median", a.cores) if have_old else None
    old_fit8 = fit(rows, OLD, "ms_median", a.cores) if have_old else None
    new_handled = fit(rows, NEW, "ms_median", a.cores, handled=True)
    whole_handled = fit(rows, WHOLE, "ms_median", a.cores, handled=True)
    out.append("\n## Cost model\n")
    out.append(f"Fitted here, per implementation: T(N, P) = α·steps(N) + γ·P·(1 − 1/N)·max(1, N/{a.cores} cores), "
               "least squares over the rows with N ≥ 2 (steps: the exchanges one rank takes part in; P: the frame's "
               "pixels, active or not: γ is a cost per frame pixel, as before). On one machine the bytes travel by "
               "memory copies and grow with the pixels, so a bandwidth term cannot be told apart from γ: γ holds "
               "scanning, packing, the shared-memory transfer, unpacking, the over operator and (radix-k) the "
               "finishing to 8 bits.\n")
    out.append("| implementation | what is timed | α (µs a step) | γ (ns a frame pixel) | median error of the fit |")
    out.append("| --- | --- | --- | --- | --- |")
    for name, what, f in ((NEW, "to the finished 8-bit frame, footprints", new_fit),
                          (WHOLE, "to the finished 8-bit frame, whole frames", whole_fit),
                          (OLD, "`composite` only (the baseline's figure)", old_fit),
                          (OLD, "to the finished 8-bit frame", old_fit8)):
        if f:
            out.append(f"| {name} | {what} | {f[0] * 1e6:.1f} | {f[1] * 1e9:.2f} | {f[2] * 100:.0f} % |")
    if new_fit and old_fit:
        out.append(f"\nγ: radix-k to the 8-bit frame {new_fit[1] * 1e9:.2f} ns against binary swap's composite alone "
                   f"{old_fit[1] * 1e9:.2f} ns, {old_fit[1] / new_fit[1]:.1f}× lower (against binary swap to the "
                   f"8-bit frame, {old_fit8[1] / new_fit[1]:.1f}×), measured in the same run; the baseline's figure "
                   "in the first report was 39 ns (other partial frames: a textured square of 3/4 the frame's side "
                   "on every rank).\n")
    out.append(f"A cost per frame pixel charges a rank for pixels it never touches once it reads only its footprint "
               f"and then only active pixels of shrinking ranges; so radix-k is fitted a second time with a cost per "
               f"pixel handled: T = α·steps(N) + γ_h·H·max(1, N/{a.cores} cores), H the most pixels one rank handled "
               "(counted by the compositor in every run).\n")
    out.append("| implementation | α (µs a step) | γ_h (ns a pixel handled) | median error of the fit |")
    out.append("| --- | --- | --- | --- |")
    for name, f in ((NEW, new_handled), (WHOLE, whole_handled)):
        if f:
            out.append(f"| {name} | {f[0] * 1e6:.1f} | {f[1] * 1e9:.2f} | {f[2] * 100:.0f} % |")
    # Counted: 8 and 64 ranks.
    counted, counted_whole = {}, {}
    out.append("\n## 8 and 64 ranks, counted\n")
    out.append("One frame each on this machine's two cores (their times say nothing of a cluster's and are left "
               "out): the most pixels one rank handled and the most bytes one rank sent, per frame pixel, which the "
               "projection scales to larger frames.\n")
    out.append("| ranks | size | footprint (mean share) | handled, whole frames | handled, footprints "
               "| bytes sent by one rank, most, a frame pixel |")
    out.append("| --- | --- | --- | --- | --- | --- |")
    for r in count_rows:
        n, size = int(r["ranks"]), int(r["size"])
        if r["impl"] in (NEW, WHOLE):
            (counted if r["impl"] == NEW else counted_whole)[n] = (float(r["handled_max_rank"]) / size ** 2,
                                                                  float(r["bytes_max_rank"]) / size ** 2)
    for r in count_rows:
        if r["impl"] != NEW:
            continue
        n, size = int(r["ranks"]), int(r["size"])
        whole = next((w for w in count_rows if w["impl"] == WHOLE and w["ranks"] == r["ranks"]), None)
        whole_text = f"{float(whole['handled_max_rank']) / size ** 2:.3f} P" if whole else "–"
        out.append(f"| {n} | {size}² | {float(r['footprint_share']) * 100:.1f} % | {whole_text} | "
                   f"{counted[n][0]:.3f} P | {counted[n][1]:.2f} B |")
    # Projection.
    out.append("\n## Projected\n")
    out.append("One core per rank: T = α_link·messages + bytes/β_link + (computing), α_link assumed 20 µs on 10 Gb/s "
               "Ethernet and 2 µs on 100 Gb/s InfiniBand, the rounds' messages and the 8-bit gather into the root "
               "(P·(1 − 1/N)·4 bytes over its one link) added, no overlap. Radix-k with `radixFactors(N)` (64: "
               f"{'x'.join(map(str, radix_factors(64)))}, 512: {'x'.join(map(str, radix_factors(512)))}). "
               "**Counted**: computing γ_h·H, H and the most bytes one rank sends taken from the counted frames of "
               "the same rank count, scaled by the pixels. **Ceiling**: the first report's form, computing "
               "γ·P·(1 − 1/N) and every rank sending P·(1 − 1/N) half-float pixels (every pixel active). Binary "
               "swap as before: P·(1 − 1/N)·8 bytes a rank over log2 N rounds, P·(1 − 1/N)·8 bytes of "
               "premultiplied halves into rank 0, its own γ (composite only, its finishing left out in its "
               "favour).\n")
    out.append("**Counted, whole frames**: the same with radix-k reading every rank's whole frame (its own fit and "
               "counts): what footprints save.\n")
    out.append("| pixels | ranks | link | radix-k, counted (s) | radix-k, counted, whole frames (s) "
               "| radix-k, ceiling (s) | binary swap (s) |")
    out.append("| --- | --- | --- | --- | --- | --- | --- |")
    projected = None
    for pixels, label in ((2048 * 2048, "2048² (4 Mpx)"), (8192 * 8192, "8192² (64 Mpx)")):
        for n in (8, 64, 512):
            for gbps, lat in ((10, 20e-6), (100, 2e-6)):
                bw = gbps / 8 * 1e9
                share = pixels * (1 - 1 / n)
                messages = sum(k - 1 for k in radix_factors(n))
                gather = lat * (n - 1) + share * 4 / bw
                cells = []
                for fitted, table in ((new_handled, counted), (whole_handled, counted_whole)):
                    if fitted and n in table:
                        handled, sent = table[n]
                        t = lat * messages + sent * pixels / bw + fitted[1] * handled * pixels + gather
                        cells.append(f"{t:.3f}")
                        if table is counted and pixels == 8192 * 8192 and n == 64 and gbps == 100:
                            projected = t
                    else:
                        cells.append("–")
                if new_fit:
                    cells.append(f"{lat * messages + share * 8 / bw + new_fit[1] * share + gather:.3f}")
                else:
                    cells.append("–")
                if old_fit:
                    swap = lat * math.log2(n) + share * 8 / bw + old_fit[1] * share
                    cells.append(f"{swap + lat * n + share * 8 / bw:.3f}")
                else:
                    cells.append("–")
                out.append(f"| {label} | {n} | {gbps} Gb/s | " + " | ".join(cells) + " |")
    if new_fit:
        pixels, n, bw = 8192 * 8192, 64, 100 / 8 * 1e9
        share = pixels * (1 - 1 / n)
        ceiling = (2e-6 * (sum(k - 1 for k in radix_factors(n)) + n - 1) + share * 8 / bw
                   + new_fit[1] * share + share * 4 / bw)
        against = f", {old_fit[1] / new_fit[1]:.1f}× below the baseline's in this run" if old_fit else ""
        counted_text = f"{projected:.2f} s" if projected is not None else "not counted"
        out.append(f"\nTargets: γ = {new_fit[1] * 1e9:.2f} ns a frame pixel{against} (aim: 10×); 64 Mpx on 64 ranks "
                   f"over 100 Gb/s projected to {counted_text} counted, {ceiling:.2f} s as a ceiling (aim: 0.3 s). "
                   "Both projections rest on γ measured on two shared cores with every rank oversubscribed (load "
                   "above), and the counted one on the bench's volume: a part's footprint is a share of the frame "
                   "that shrinks with the rank count as its box does; a volume seen edge-on or filling the frame "
                   "from inside gives larger footprints (the camera inside the data: the whole frame, as in the "
                   "whole-frames column, and more active pixels a rank than the bench's, which the ceiling "
                   "bounds).")
    out.append("\nPublished, for scale: radix-k composited 64 Mpx in 0.08 s on 32 k processes and ran 40 % faster "
               "than binary swap from 32 to 35 k processes (Kendall et al., EGPGV 2010, on Blue Gene/P and a "
               "Cray XT); IceT composited at 64 k cores (Moreland et al., SC11). Both leave the image distributed "
               "or reduce it with far more links than one root has; here the gather into one root is bounded by "
               "the root's link (P·4 bytes) however many ranks there are.\n")
    print("\n".join(out))


if __name__ == "__main__":
    main()
