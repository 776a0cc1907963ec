#!/usr/bin/python3
"""Memory of `voxbrick.prep` (python/voxbrick/arrays.py) on a large array, measured.

Makes an N³ float32 array as a NumPy memory map on disk (N = 1024 by default: 4.3 GB; 768 when the work disk has
under 20 GB free), filled slab by slab with a smooth synthetic field (Gaussian blobs), and preps it from Python, each
case in a fresh Python process:

  in-place    the np.memmap itself (C-contiguous, axes z, y, x, float32): prep's header points into its file, Python
              copies nothing;
  copied      the same voxels as a plain ndarray view of the map, as prep gets a map it cannot read in place (another
              dtype, a strided view, an array whose base is the map): written slab by slab to a raw file, then prepped;
  transposed  the same field in a second map laid out x, y, z (z fastest, as nibabel indexes volumes), prepped with
              axes="xyz": each slab of z-slices gathered from across the whole file.

For each: the Python process's peak resident set (VmHWM) and the peaks of its anonymous and file-backed parts (RssAnon,
RssFile, sampled every 20 ms); the `voxbrick prep` child's own peak (its VmHWM, sampled), beside what getrusage
RUSAGE_CHILDREN and prep's summary line say (both ru_maxrss, which on Linux also counts the parent's resident set at
the time it started the child); the wall time; a digest of the store's bricks (the three cases must give one store).
Beside them the store's working memory as prep computes it (the least `--memory` it accepts for this input, from its
own refusal of `--memory 128`) and its default bound (`--memory 1024`). Writes
bench/results/python/prep-memory.{md,csv}, then deletes the arrays and the stores.

    /usr/bin/python3 bench/run_python_prep.py [--n 1024] [--exe build/voxbrick] [--work bench/work/python-prep]
        [--package python] [--cases in-place,copied,transposed] [--keep] [--label TEXT] [--append]

Run with Debian's /usr/bin/python3 (NumPy). `--package` takes another copy of the package (an older version, to
compare); `--label` names the run in the results, `--append` adds it to them; `--keep` keeps the arrays for a next run.
"""
from __future__ import annotations

import argparse
import contextlib
import csv
import datetime
import hashlib
import io
import json
import os
import platform
import re
import resource
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

SOURCE_DIR = Path(__file__).resolve().parents[1]
GB = 1e9
MiB = 1 << 20
PROC = Path('/proc')


def status(pid: str = 'self') -> dict:
    """The memory figures of /proc/PID/status, in bytes."""
    out = {}
    with open(PROC / pid / 'status') as f:
        for line in f:
            key, _, value = line.partition(':')
            if key in ('VmRSS', 'VmHWM', 'RssAnon', 'RssFile', 'RssShmem'):
                out[key] = int(value.split()[0]) * 1024
    return out


def children_hwm() -> int:
    """The largest VmHWM of this process's children now (0 if none): a child's own peak since it ran its program."""
    peak = 0
    for task in os.listdir(PROC / 'self' / 'task'):
        try:
            pids = (PROC / 'self' / 'task' / task / 'children').read_text().split()
        except OSError:
            continue
        for pid in pids:
            try:
                peak = max(peak, status(pid).get('VmHWM', 0))
            except OSError:
                pass
    return peak


class Sampler(threading.Thread):
    """Peaks of this process's RssAnon and RssFile (VmHWM has only their sum) and of its children's VmHWM, read every
    `period` seconds."""

    def __init__(self, period: float = 0.02):
        super().__init__(daemon=True)
        self.period, self.stopping = period, False
        self.peaks = {'RssAnon': 0, 'RssFile': 0, 'VmRSS': 0, 'children': 0}

    def sample(self, children: bool = True) -> None:
        s = status()
        if children:
            s['children'] = children_hwm()
        for k in self.peaks:
            self.peaks[k] = max(self.peaks[k], s.get(k, 0))

    def run(self):
        while not self.stopping:
            self.sample()
            time.sleep(self.period)

    def stop(self) -> dict:
        self.stopping = True
        self.join()
        self.sample(children=False)
        return dict(self.peaks)


#: The layouts of the field's maps: the array's axes, slowest first.
LAYOUTS = ('zyx', 'xyz')


def fill_field(mm, layout: str, n: int, slab_mb: int, count: int = 8, seed: int = 1) -> None:
    """Fills the map `mm` (n³, axes `layout`, slowest first) with `count` Gaussian blobs, a slab along its slowest axis
    at a time: v(x, y, z) = sum over k of c_k[z] * p_k[y, x], c_k = a_k g_k,z and p_k = g_k,y g_k,x (each blob is
    separable). Every voxel's value is the same float32 operations in the same order for every layout, so the maps of
    the two layouts hold the same field bit for bit."""
    import mmap
    import numpy as np
    rng = np.random.default_rng(seed)
    coordinate = np.arange(n, dtype=np.float32)
    centres = rng.uniform(0.2, 0.8, (count, 3)) * n  # x, y, z
    sigmas = rng.uniform(0.06, 0.16, count) * n
    amplitudes = rng.uniform(0.5, 1.0, count).astype(np.float32)
    g = [[np.exp(-((coordinate - centres[k, i]) ** 2) / (2 * sigmas[k] ** 2)).astype(np.float32) for i in range(3)]
         for k in range(count)]
    c = [amplitudes[k] * g[k][2] for k in range(count)]  # along z
    p = [np.outer(g[k][1], g[k][0]) for k in range(count)]  # [y, x]
    thickness = max(1, slab_mb * MiB // (n * n * 4))
    term = np.empty((thickness, n, n), dtype=np.float32)
    for i0 in range(0, n, thickness):
        i1 = min(n, i0 + thickness)
        slab, t = mm[i0:i1], term[:i1 - i0]
        slab[...] = 0
        for k in range(count):
            if layout == 'zyx':  # slab[z, y, x]
                np.multiply(c[k][i0:i1, None, None], p[k][None, :, :], out=t)
            else:  # slab[x, y, z]
                np.multiply(c[k][None, None, :], p[k].T[i0:i1, :, None], out=t)
            slab += t
        # Written back and dropped from this process's mapping (the page cache keeps it): the fill's resident set stays
        # one slab, not the whole file.
        mm.flush()
        start = i0 * n * n * 4 // mmap.PAGESIZE * mmap.PAGESIZE
        mm._mmap.madvise(mmap.MADV_DONTNEED, start, i1 * n * n * 4 - start)


def phase_fill(args) -> dict:
    import numpy as np
    t0 = time.monotonic()
    sampler = Sampler()
    sampler.start()
    mm = np.memmap(args.array, dtype=np.float32, mode='w+', shape=(args.n,) * 3)
    fill_field(mm, args.layout, args.n, args.slab_mb)
    del mm
    os.sync()
    peaks = sampler.stop()
    return {'wall_s': time.monotonic() - t0, 'hwm': status()['VmHWM'], 'anon_peak': peaks['RssAnon'],
            'file_peak': peaks['RssFile']}


def digest(store: Path) -> str:
    """A digest of the store's bricks and index (its OpenVDB files hold a random UUID each)."""
    h = hashlib.blake2b(digest_size=8)
    for name in ('index.bin', 'bricks.bin'):
        with open(store / name, 'rb') as f:
            while chunk := f.read(16 * MiB):
                h.update(chunk)
    return h.hexdigest()


def phase_prep(args) -> dict:
    """voxbrick.prep of one case, in this fresh process."""
    import numpy as np
    sys.path.insert(0, str(args.package))
    import voxbrick
    import voxbrick.arrays  # noqa: F401 (imported before the baseline is read)
    mm = np.memmap(args.array, dtype=np.float32, mode='r', shape=(args.n,) * 3)
    array = np.asarray(mm) if args.case == 'copied' else mm
    axes = 'xyz' if args.case == 'transposed' else 'zyx'
    baseline = status()
    out = Path(args.work) / f'{args.case}.vbs'
    shutil.rmtree(out, ignore_errors=True)
    sampler = Sampler()
    sampler.start()
    t0 = time.monotonic()
    said = io.StringIO()
    with contextlib.redirect_stdout(said):
        voxbrick.prep(array, out, axes=axes, exe=args.exe, quiet=False, work=args.work)
    wall = time.monotonic() - t0
    peaks = sampler.stop()
    hwm = status()['VmHWM']
    rusage = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024
    text = said.getvalue()
    m = re.search(r'peak RSS ([0-9.]+) (MB|GB)', text)
    child_said = float(m.group(1)) * (1e9 if m.group(2) == 'GB' else 1e6) if m else None
    m = re.search(r'([0-9.]+) s, ([0-9.]+) MB/s in', text)
    store_bytes = sum(f.stat().st_size for f in out.rglob('*') if f.is_file())
    bricks = digest(out)
    shutil.rmtree(out, ignore_errors=True)
    return {'case': args.case, 'wall_s': wall, 'baseline': baseline['VmRSS'], 'hwm': hwm,
            'anon_peak': peaks['RssAnon'], 'file_peak': peaks['RssFile'], 'child_hwm': peaks['children'],
            'child_rusage': rusage, 'child_said': child_said, 'prep_s': float(m.group(1)) if m else None,
            'store_bytes': store_bytes, 'digest': bricks,
            'summary': [line for line in text.splitlines() if line.startswith('prep: ')]}


def run_phase(args, phase: str, array: Path, **extra) -> dict:
    cmd = [sys.executable, __file__, '--phase', phase, '--n', str(args.n), '--work', str(args.work), '--array',
           str(array), '--exe', str(args.exe), '--package', str(args.package), '--slab-mb', str(args.slab_mb)]
    for k, v in extra.items():
        cmd += [f'--{k}', str(v)]
    r = subprocess.run(cmd, stdout=subprocess.PIPE, text=True)
    if r.returncode != 0:
        raise SystemExit(f'run_python_prep: phase {phase} {extra} failed ({r.returncode})')
    return json.loads(r.stdout.strip().splitlines()[-1])


def working_memory(args, array: Path) -> int:
    """The least --memory prep accepts for this input (its refusal names it), in MB."""
    r = subprocess.run([str(args.exe), 'prep', str(array), '--dims', f'{args.n},{args.n},{args.n}', '--type', 'f32',
                        '--memory', '128', '-q', '-o', str(Path(args.work) / 'refused.vbs')],
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    m = re.search(r'needs at least (\d+) MB', r.stdout)
    if not m:
        raise SystemExit(f'run_python_prep: prep did not name its working memory: {r.stdout}')
    return int(m.group(1))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument('--n', type=int, default=0, help='the array side (default 1024; 768 under 20 GB free)')
    p.add_argument('--exe', default=str(SOURCE_DIR / 'build' / 'voxbrick'))
    p.add_argument('--work', default=str(SOURCE_DIR / 'bench' / 'work' / 'python-prep'))
    p.add_argument('--package', default=str(SOURCE_DIR / 'python'))
    p.add_argument('--cases', default='in-place,copied,transposed')
    p.add_argument('--slab-mb', type=int, default=64, help="slabs of the fill (prep's own slab_bytes is its default)")
    p.add_argument('--keep', action='store_true', help='keep the arrays')
    p.add_argument('--label', default='')
    p.add_argument('--append', action='store_true', help='add this run to the results (a section, rows) instead of '
                   'replacing them')
    p.add_argument('--results', default=str(SOURCE_DIR / 'bench' / 'results' / 'python' / 'prep-memory'))
    p.add_argument('--phase', help=argparse.SUPPRESS)
    p.add_argument('--array', help=argparse.SUPPRESS)
    p.add_argument('--layout', help=argparse.SUPPRESS)
    p.add_argument('--case', help=argparse.SUPPRESS)
    args = p.parse_args()
    args.exe, args.work, args.package = (os.path.abspath(v) for v in (args.exe, args.work, args.package))
    if args.phase:
        print(json.dumps({'fill': phase_fill, 'prep': phase_prep}[args.phase](args)))
        return

    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    cases = args.cases.split(',')
    unknown = set(cases) - {'in-place', 'copied', 'transposed'}
    if unknown:
        raise SystemExit(f'run_python_prep: unknown cases {sorted(unknown)}')
    free = shutil.disk_usage(work).free
    df = subprocess.run(['df', '-h', str(work)], stdout=subprocess.PIPE, text=True).stdout.strip()
    print(df)
    note = ''
    if not args.n:
        args.n = 1024 if free >= 20 * GB else 768
        if args.n == 768:
            note = f'{free / GB:.1f} GB free on the work disk, under 20 GB: 768³ instead of 1024³'
            print(f'run_python_prep: {note}')
    size = args.n ** 3 * 4
    arrays = {layout: work / f'field-{args.n}-{layout}.f32' for layout in LAYOUTS}
    needed = {'zyx': any(c in ('in-place', 'copied') for c in cases), 'xyz': 'transposed' in cases}
    command = 'python3 bench/run_python_prep.py ' + ' '.join(sys.argv[1:])
    load_start = os.getloadavg()
    started = datetime.datetime.now(datetime.timezone.utc)
    fills = {}
    try:
        for layout, path in arrays.items():
            if not needed[layout]:
                continue
            if path.exists() and path.stat().st_size == size:
                print(f'run_python_prep: reusing {path}')
            else:
                fills[layout] = run_phase(args, 'fill', path, layout=layout)
                print(f'fill {layout}: {fills[layout]}')
        needs = working_memory(args, arrays['zyx'] if needed['zyx'] else arrays['xyz'])
        rows = []
        for case in cases:
            r = run_phase(args, 'prep', arrays['xyz' if case == 'transposed' else 'zyx'], case=case)
            print(f'{case}: ' + json.dumps(r))
            rows.append(r)
    finally:
        for f in list(work.glob('*.vbs')) + list(work.glob('.voxbrick-prep-*')):
            shutil.rmtree(f, ignore_errors=True)
        if not args.keep:
            for path in arrays.values():
                path.unlink(missing_ok=True)
    load_end = os.getloadavg()
    write_results(args, rows, fills, needs, size, note, command, started, load_start, load_end)


def write_results(args, rows, fills, needs, size, note, command, started, load_start, load_end) -> None:
    commit = subprocess.run(['git', '-C', str(SOURCE_DIR), 'rev-parse', '--short', 'HEAD'], stdout=subprocess.PIPE,
                            text=True).stdout.strip()
    dirty = subprocess.run(['git', '-C', str(SOURCE_DIR), 'status', '--porcelain', '--', 'python'],
                           stdout=subprocess.PIPE, text=True).stdout.strip()
    cpu = next((line.split(':', 1)[1].strip() for line in open(PROC / 'cpuinfo') if line.startswith('model name')),
               platform.processor())
    mem = next(int(line.split()[1]) * 1024 for line in open(PROC / 'meminfo') if line.startswith('MemTotal'))
    package = os.path.relpath(args.package, SOURCE_DIR)
    results = Path(args.results)
    results.parent.mkdir(parents=True, exist_ok=True)
    slab = 64 * MiB  # prep's slab_bytes default
    mb = lambda b: f'{b / 1e6:.0f}' if b is not None else ''  # noqa: E731
    append = args.append and results.with_suffix('.csv').exists()
    with open(results.with_suffix('.csv'), 'a' if append else 'w', newline='') as f:
        w = csv.writer(f, lineterminator='\n')
        if not append:
            w.writerow(['label', 'case', 'n', 'array_mb', 'python_baseline_mb', 'python_peak_mb',
                        'python_anon_peak_mb', 'python_file_peak_mb', 'child_peak_mb', 'child_rusage_mb',
                        'child_said_mb', 'store_min_memory_mb', 'store_memory_bound_mb', 'slab_mb', 'wall_s',
                        'prep_s', 'store_mb', 'bricks_digest'])
        for r in rows:
            w.writerow([args.label, r['case'], args.n, mb(size), mb(r['baseline']), mb(r['hwm']), mb(r['anon_peak']),
                        mb(r['file_peak']), mb(r['child_hwm']), mb(r['child_rusage']), mb(r['child_said']), needs,
                        1024, mb(slab), f'{r["wall_s"]:.1f}', r['prep_s'], mb(r['store_bytes']), r['digest']])
    title = f'Memory of `voxbrick.prep` on a {args.n}³ float32 array' + (f': {args.label}' if args.label else '')
    filled = '; '.join(f'{layout} in {v["wall_s"]:.1f} s (the filling process: peak RSS {mb(v["hwm"])} MB)'
                       for layout, v in fills.items()) or 'kept from a run before'
    lines = [
        f'{"##" if append else "#"} {title}',
        '',
        f'{started:%Y-%m-%d %H:%M} UTC, commit {commit}{" with python/ changed" if dirty else ""}. Machine: '
        f'{os.cpu_count()}-core virtual machine ({cpu}, {mem / 2**30:.0f} GiB), shared with other work and loaded '
        f'(load average {load_start[0]:.1f} at the start, {load_end[0]:.1f} at the end). The package from '
        f'`{package}`, `voxbrick` from `{os.path.relpath(args.exe, SOURCE_DIR)}`.',
        '',
        f'Command: `{command}`',
        '',
        f'The arrays: np.memmap files of {args.n}³ float32 ({size / 1e9:.2f} GB each), Gaussian blobs, filled slab '
        f'by slab ({filled}).' + (f' {note}.' if note else ''),
        f'The store\'s working memory for this input, as prep computes it: **{needs} MB** (the least `--memory` it '
        f'accepts: its refusal of `--memory 128`); its bound by default is `--memory 1024`. `voxbrick.prep` reads '
        f'and writes slabs of {slab // MiB} MiB (`slab_bytes`).',
        '',
        '| case | Python before prep | **Python peak** (VmHWM) | of it anonymous | of it file-backed | `voxbrick prep` '
        'own peak (VmHWM) | its ru_maxrss (summary line) | wall | bricks digest |',
        '| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |',
    ]
    for r in rows:
        lines.append(f'| {r["case"]} | {mb(r["baseline"])} MB | **{mb(r["hwm"])} MB** | {mb(r["anon_peak"])} MB | '
                     f'{mb(r["file_peak"])} MB | {mb(r["child_hwm"])} MB | {mb(r["child_rusage"])} MB '
                     f'({mb(r["child_said"])} MB) | {r["wall_s"]:.1f} s | `{r["digest"]}` |')
    lines += ['', 'prep\'s own lines:', '']
    for r in rows:
        lines += [f'- {r["case"]}: ' + ' / '.join(f'`{s}`' for s in r['summary'])]
    lines.append('')
    with open(results.with_suffix('.md'), 'a' if append else 'w') as f:
        f.write(('\n' if append else '') + '\n'.join(lines))
    print('\n'.join(lines))


if __name__ == '__main__':
    main()
