#!/usr/bin/python3
"""`client.upload` (python/voxbrick/client.py) against `voxbrick.prep` of the same array: time, memory, the store.

Makes an N³ float32 array of smooth Gaussian blobs with NumPy (N = 256 by default: 64 MiB; `--n 256,512` runs each
size in turn), saved once as a .npy file that every case loads whole into its own memory (a plain in-memory ndarray,
axes z, y, x). Starts two `voxbrick serve` processes on free ports that take uploads from their --http-token (server A
with the default message limit, 1 MiB; server B with `--max-message-bytes 16777216`), then runs, each in a FRESH
Python process so that its peak resident set (VmHWM) is its own:

  prep      `voxbrick.prep(array, out)` locally: the same work without a server (the peer);
  tcp-1m    `voxbrick.connect("127.0.0.1:PORT", token=...).upload(name, array)` to server A: 1 MiB messages, chunks
            of 1 MiB - 4 bytes;
  tcp-16m   the same to server B: chunks of 16 MiB - 4 bytes;
  ws-1m     the same over server A's WebSocket ("ws://127.0.0.1:HTTPPORT", the token given at the upgrade).

The cases alternate in rounds (`--rounds`, the order rotated each round); every upload has its own name
(bench-CASE-N-ROUND) and its store is deleted once measured, as is each local store.

For each run: the wall time of the call (prep() or upload(), the connection made before it); the Python process's
resident set before the call (the array, N³·4 bytes, is in it) and its peak during the call (VmHWM, reset by
/proc/self/clear_refs just before the call), so the call's own memory is the difference; its CPU time in the call.
The `voxbrick prep` child's lifetime and peak (VmHWM), sampled every 20 ms by this process from /proc (the server's
child for an upload, the Python process's for a local prep). For an upload, the server's side: its log's
millisecond timestamps of "upload 'NAME' of B bytes started" (the Upload arrived) and "... prepped into" (the store
in place), and between them the moment its prep child appeared (all chunks arrived): the transfer and the prep;
the server's own CPU time (prep's excluded) and the growth of its resident set. The store's bricks.bin and index.bin
are digested and compared with the local prep's: the store must be the same.

    nice /usr/bin/python3 bench/run_python_upload.py [--n 256[,512]] [--rounds 3] [--cases prep,tcp-1m,tcp-16m,ws-1m]
        [--exe build/voxbrick] [--work bench/work/python-upload] [--package python] [--label TEXT] [--append]
        [--keep]

Run with Debian's /usr/bin/python3 (NumPy). Writes bench/results/python/upload.{md,csv} (`--append` adds this run to
them); `--keep` keeps the .npy arrays for a next run.
"""
from __future__ import annotations

import argparse
import csv
import datetime
import hashlib
import json
import os
import platform
import re
import resource
import shutil
import signal
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path

SOURCE_DIR = Path(__file__).resolve().parents[1]
MiB = 1 << 20
PROC = Path('/proc')
TOKEN = 'bench-upload-token'
CASES = ('prep', 'tcp-1m', 'tcp-16m', 'ws-1m')
BIG_MESSAGES = 16 * MiB  # server B's --max-message-bytes
TICK = os.sysconf('SC_CLK_TCK')


def status(pid='self') -> dict:
    """The memory figures of /proc/PID/status, in bytes."""
    out = {}
    with open(PROC / str(pid) / 'status') as f:
        for line in f:
            key, _, value = line.partition(':')
            if key in ('VmRSS', 'VmHWM', 'RssAnon', 'RssFile'):
                out[key] = int(value.split()[0]) * 1024
    return out


def cpu_times(pid) -> tuple:
    """(own, reaped children's) CPU seconds of process `pid` and its own minor page faults, from /proc/PID/stat."""
    fields = (PROC / str(pid) / 'stat').read_text().rsplit(')', 1)[1].split()
    # After the command's ')': state is field 3, minflt field 10; utime, stime, cutime, cstime are fields 14 to 17.
    utime, stime, cutime, cstime = (int(v) for v in fields[11:15])
    return (utime + stime) / TICK, (cutime + cstime) / TICK, int(fields[7])


def forked(pid) -> float:
    """When process `pid` was forked, as time.time(), from its start time in /proc/PID/stat (clock ticks since boot,
    10 ms apart)."""
    fields = (PROC / str(pid) / 'stat').read_text().rsplit(')', 1)[1].split()
    since_boot = int(fields[19]) / TICK  # field 22, starttime
    return time.time() - (time.clock_gettime(time.CLOCK_BOOTTIME) - since_boot)


def children(pid) -> list:
    out = []
    try:
        for task in os.listdir(PROC / str(pid) / 'task'):
            try:
                out += [int(c) for c in (PROC / str(pid) / 'task' / task / 'children').read_text().split()]
            except OSError:
                pass
    except OSError:
        pass
    return out


def descendants(pid) -> list:
    out, todo = [], children(pid)
    while todo:
        c = todo.pop()
        out.append(c)
        todo += children(c)
    return out


class PrepWatch(threading.Thread):
    """Every `period` s: the `voxbrick prep` processes below the `roots` (first and last time seen, peak VmHWM, as
    time.time()) and the peak VmRSS of `server` (a pid, or None)."""

    def __init__(self, roots: list, server, period: float = 0.02):
        super().__init__(daemon=True)
        self.roots, self.server, self.period, self.stopping = roots, server, period, False
        self.preps = {}  # pid: {'first', 'last', 'hwm'}
        self.server_rss = 0

    def sample(self) -> None:
        now = time.time()
        for root in self.roots:
            for pid in descendants(root):
                try:
                    argv = (PROC / str(pid) / 'cmdline').read_bytes().split(b'\0')
                    if len(argv) < 2 or argv[1] != b'prep':
                        continue  # not yet exec'd (a fork of the server), or something else
                    hwm = status(pid).get('VmHWM', 0)
                except OSError:
                    continue
                p = self.preps.setdefault(pid, {'first': now, 'last': now, 'hwm': 0, 'forked': forked(pid)})
                p['last'], p['hwm'] = now, max(p['hwm'], hwm)
        if self.server:
            try:
                self.server_rss = max(self.server_rss, status(self.server)['VmRSS'])
            except OSError:
                pass

    def run(self):
        while not self.stopping:
            self.sample()
            time.sleep(self.period)

    def stop(self) -> dict:
        self.stopping = True
        self.join()
        if len(self.preps) != 1:
            raise SystemExit(f'run_python_upload: saw {len(self.preps)} prep processes in one run, not one')
        return next(iter(self.preps.values()))


def fill(path: Path, n: int, slab_mb: int = 16) -> None:
    """`path`: an .npy file of an n³ float32 array (axes z, y, x) of Gaussian blobs: run_python_prep.py's field, filled
    slab by slab."""
    import numpy as np
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from run_python_prep import fill_field
    mm = np.lib.format.open_memmap(path, mode='w+', dtype=np.float32, shape=(n, n, n))
    fill_field(mm, 'zyx', n, slab_mb)
    mm.flush()
    del mm


def phase_case(args) -> dict:
    """One case in this fresh process: the array loaded, the connection made, then the call measured."""
    import numpy as np
    sys.path.insert(0, args.package)
    import voxbrick
    import voxbrick.arrays  # noqa: F401
    from voxbrick.protocol import MessageType
    array = np.load(args.array)  # read whole into this process's memory: a plain C-contiguous ndarray
    assert array.flags.c_contiguous and array.dtype == np.float32
    client, marks = None, {'chunks': 0, 'last_chunk': None}
    if args.case != 'prep':
        client = voxbrick.connect(args.address, token=TOKEN, timeout=900)
        send = client.session._send

        def counted(message_type, **fields):  # the moment each chunk was handed to the socket
            r = send(message_type, **fields)
            if message_type == MessageType.UploadChunk:
                marks['chunks'] += 1
                marks['last_chunk'] = time.time()
            return r
        client.session._send = counted
    with open('/proc/self/clear_refs', 'w') as f:
        f.write('5')  # VmHWM := VmRSS: the peak from here on is the call's
    before = status()
    cpu0, rusage0 = time.process_time(), resource.getrusage(resource.RUSAGE_CHILDREN)
    faults0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    t0, m0 = time.time(), time.monotonic()
    if client is None:
        voxbrick.prep(array, args.out, exe=args.exe)
        info = None
    else:
        info = client.upload(args.name, array)
    wall = time.monotonic() - m0
    t1 = time.time()
    cpu = time.process_time() - cpu0
    faults = resource.getrusage(resource.RUSAGE_SELF).ru_minflt - faults0
    rusage1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    after = status()
    out = {'t0': t0, 't1': t1, 'wall_s': wall, 'cpu_s': cpu, 'before': before['VmRSS'], 'hwm_before': before['VmHWM'],
           'hwm': after['VmHWM'], 'faults': faults, 'array_bytes': array.nbytes, 'chunks': marks['chunks'],
           'last_chunk': marks['last_chunk'],
           'children_cpu_s': (rusage1.ru_utime + rusage1.ru_stime) - (rusage0.ru_utime + rusage0.ru_stime)}
    if client is not None:
        out['chunk_bytes'] = client.capabilities.max_message_bytes - 4
        out['version'] = client.version
        out['dims'] = info.get('dims')
        client.close()
    return out


def digest(path: Path) -> str:
    h = hashlib.blake2b(digest_size=8)
    with open(path, 'rb') as f:
        while chunk := f.read(16 * MiB):
            h.update(chunk)
    return h.hexdigest()


class Server:
    """A `voxbrick serve` over `datasets` taking uploads from TOKEN, on free ports (as tests/python/conftest.py)."""

    def __init__(self, exe: str, work: Path, name: str, extra: tuple = ()):
        self.datasets = work / f'datasets-{name}'
        shutil.rmtree(self.datasets, ignore_errors=True)
        self.datasets.mkdir(parents=True)
        port_file, http_file = work / f'{name}.port', work / f'{name}.http-port'
        for f in (port_file, http_file):
            f.unlink(missing_ok=True)
        self.log = work / f'serve-{name}.log'
        self.command = [exe, 'serve', '--no-config', '--datasets', str(self.datasets), '--port', '0', '--port-file',
                        str(port_file), '--http', '0', '--http-port-file', str(http_file), '--http-token', TOKEN,
                        '--upload-max-mb', '2048', '--render-threads', '1', *extra]
        with open(self.log, 'w') as log:
            self.process = subprocess.Popen(self.command, stdout=log, stderr=subprocess.STDOUT)
        deadline = time.monotonic() + 60
        while not all(p.exists() and p.read_text().strip() for p in (port_file, http_file)):
            if self.process.poll() is not None or time.monotonic() > deadline:
                self.stop()
                raise SystemExit(f'run_python_upload: the server did not start: {self.log.read_text()}')
            time.sleep(0.02)
        self.tcp = f'127.0.0.1:{int(port_file.read_text())}'
        self.ws = f'ws://127.0.0.1:{int(http_file.read_text())}'

    def logged(self, name: str, what: str, wait: float = 5.0) -> float:
        """The time (time.time()) of the log line "upload 'NAME' of B bytes WHAT"."""
        pattern = re.compile(r"^\[(\d{4}-\d\d-\d\d \d\d:\d\d:\d\d\.\d{3})\] \[info\] upload '" + re.escape(name) +
                             r"' of \d+ bytes " + re.escape(what))
        deadline = time.monotonic() + wait
        while True:
            for line in self.log.read_text().splitlines():
                m = pattern.match(line)
                if m:  # the server logs local time, as time.time() is read here (one machine)
                    return datetime.datetime.strptime(m.group(1), '%Y-%m-%d %H:%M:%S.%f').timestamp()
            if time.monotonic() > deadline:
                raise SystemExit(f'run_python_upload: no line "upload \'{name}\' ... {what}" in {self.log}')
            time.sleep(0.1)

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()


def run_case(args, case: str, n: int, round_: int, array: Path, servers: dict) -> dict:
    name = f'bench-{case}-{n}-{round_}'
    server = None if case == 'prep' else servers['b' if case == 'tcp-16m' else 'a']
    out = Path(args.work) / f'{name}.vbs'
    cmd = [sys.executable, __file__, '--phase', 'case', '--case', case, '--array', str(array), '--exe', args.exe,
           '--package', args.package, '--name', name, '--out', str(out)]
    if server:
        cmd += ['--address', server.ws if case == 'ws-1m' else server.tcp]
        cpu_before = cpu_times(server.process.pid)
        rss_before = status(server.process.pid)['VmRSS']
    child = subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True)
    watch = PrepWatch([child.pid] + ([server.process.pid] if server else []), server.process.pid if server else None)
    watch.start()
    stdout, _ = child.communicate()
    prep = watch.stop()
    if child.returncode != 0:
        raise SystemExit(f'run_python_upload: case {case} ({name}) failed ({child.returncode})')
    r = json.loads(stdout.strip().splitlines()[-1])
    r.update({'case': case, 'n': n, 'round': round_, 'name': name, 'prep_forked': prep['forked'],
              'prep_first': prep['first'],
              'prep_last': prep['last'], 'prep_child_s': prep['last'] - prep['first'], 'prep_hwm': prep['hwm']})
    if server:
        cpu_after = cpu_times(server.process.pid)
        r['server_cpu_s'] = cpu_after[0] - cpu_before[0]
        r['server_prep_cpu_s'] = cpu_after[1] - cpu_before[1]  # the prep child's, reaped by the server
        r['server_faults'] = cpu_after[2] - cpu_before[2]
        r['server_rss_before'], r['server_rss_peak'] = rss_before, max(watch.server_rss, rss_before)
        started, prepped = server.logged(name, 'started'), server.logged(name, 'prepped into')
        r['started'], r['prepped'] = started, prepped
        r['server_total_s'] = prepped - started
        r['transfer_s'] = prep['forked'] - started  # the Upload's arrival to the prep child's start: the chunks
        r['prep_s'] = prepped - prep['forked']  # prep, its store moved into place
        r['send_s'] = r['last_chunk'] - r['t0']  # the client's side: the call's start to its last chunk handed over
        store = server.datasets / name
    else:
        r['write_s'] = prep['forked'] - r['t0']  # the raw file written before the prep child starts
        r['prep_s'] = r['t1'] - prep['forked']
        store = out
    r['store_bytes'] = sum(f.stat().st_size for f in store.rglob('*') if f.is_file())
    r['bricks'], r['index'] = digest(store / 'bricks.bin'), digest(store / 'index.bin')
    shutil.rmtree(store)
    return r


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument('--n', default='256', help='array sides, comma separated (default 256)')
    p.add_argument('--rounds', type=int, default=3)
    p.add_argument('--cases', default=','.join(CASES))
    p.add_argument('--exe', default=str(SOURCE_DIR / 'build' / 'voxbrick'))
    p.add_argument('--work', default=str(SOURCE_DIR / 'bench' / 'work' / 'python-upload'))
    p.add_argument('--package', default=str(SOURCE_DIR / 'python'))
    p.add_argument('--keep', action='store_true', help='keep the arrays')
    p.add_argument('--label', default='')
    p.add_argument('--append', action='store_true', help='add this run to the results instead of replacing them')
    p.add_argument('--results', default=str(SOURCE_DIR / 'bench' / 'results' / 'python' / 'upload'))
    p.add_argument('--phase', help=argparse.SUPPRESS)
    p.add_argument('--case', help=argparse.SUPPRESS)
    p.add_argument('--array', help=argparse.SUPPRESS)
    p.add_argument('--name', help=argparse.SUPPRESS)
    p.add_argument('--out', help=argparse.SUPPRESS)
    p.add_argument('--address', help=argparse.SUPPRESS)
    args = p.parse_args()
    args.exe, args.work, args.package = (os.path.abspath(v) for v in (args.exe, args.work, args.package))
    if args.phase == 'case':
        print(json.dumps(phase_case(args)))
        return
    if args.phase == 'fill':
        fill(Path(args.array), int(args.n))
        return

    cases = args.cases.split(',')
    unknown = set(cases) - set(CASES)
    if unknown:
        raise SystemExit(f'run_python_upload: unknown cases {sorted(unknown)}')
    sizes = [int(v) for v in args.n.split(',')]
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    command = 'nice /usr/bin/python3 bench/run_python_upload.py ' + ' '.join(sys.argv[1:])
    started = datetime.datetime.now(datetime.timezone.utc)
    load_start = os.getloadavg()
    rows, fills, servers = [], {}, {}
    arrays = {n: work / f'blobs-{n}.npy' for n in sizes}
    try:
        if any(c != 'prep' for c in cases):
            servers['a'] = Server(args.exe, work, 'a')
            servers['b'] = Server(args.exe, work, 'b', ('--max-message-bytes', str(BIG_MESSAGES)))
        for n in sizes:
            if arrays[n].exists() and 0 <= arrays[n].stat().st_size - n ** 3 * 4 < 4096:
                fills[n] = None
                print(f'run_python_upload: reusing {arrays[n]}')
            else:
                t = time.monotonic()
                subprocess.run([sys.executable, __file__, '--phase', 'fill', '--n', str(n), '--array',
                                str(arrays[n])], check=True)
                fills[n] = time.monotonic() - t
            for round_ in range(args.rounds):
                order = cases[round_ % len(cases):] + cases[:round_ % len(cases)]
                for case in order:
                    r = run_case(args, case, n, round_, arrays[n], servers)
                    print(json.dumps({k: (round(v, 3) if isinstance(v, float) else v) for k, v in r.items()}),
                          flush=True)
                    rows.append(r)
    finally:
        for s in servers.values():
            s.stop()
        for f in work.glob('*.vbs'):
            shutil.rmtree(f, ignore_errors=True)
        if not args.keep:
            for path in arrays.values():
                path.unlink(missing_ok=True)
    load_end = os.getloadavg()
    write_results(args, rows, sizes, cases, fills, servers, command, started, load_start, load_end)


def write_results(args, rows, sizes, cases, fills, servers, command, started, load_start, load_end) -> None:
    git = lambda *a: subprocess.run(['git', '-C', str(SOURCE_DIR), *a], stdout=subprocess.PIPE,  # noqa: E731
                                    text=True).stdout
    commit = git('rev-parse', '--short', 'HEAD').strip()
    changed = [line[3:] for line in git('status', '--porcelain').splitlines() if line.strip()]
    cpu = next((line.split(':', 1)[1].strip() for line in open(PROC / 'cpuinfo') if line.startswith('model name')),
               platform.processor())
    mem = next(int(line.split()[1]) * 1024 for line in open(PROC / 'meminfo') if line.startswith('MemTotal'))
    results = Path(args.results)
    results.parent.mkdir(parents=True, exist_ok=True)
    mb = lambda b: f'{b / 1e6:.0f}' if b is not None else ''  # noqa: E731
    s = lambda v: f'{v:.2f}' if v is not None else ''  # noqa: E731
    columns = ['label', 'n', 'array_mb', 'round', 'case', 'name', 'chunk_bytes', 'chunks', 'wall_s', 'cpu_s',
               'python_before_mb', 'python_peak_mb', 'python_extra_mb', 'send_s', 'write_s', 'server_total_s',
               'transfer_s', 'prep_s', 'prep_child_s', 'prep_child_peak_mb', 'prep_cpu_s', 'client_minor_faults',
               'server_cpu_s', 'server_minor_faults',
               'server_rss_before_mb', 'server_rss_growth_mb', 'store_mb', 'bricks_digest', 'index_digest',
               'same_as_prep']
    reference = {}
    for r in rows:
        if r['case'] == 'prep':
            reference.setdefault(r['n'], (r['bricks'], r['index']))
    for r in rows:
        ref = reference.get(r['n'])
        r['same'] = '' if ref is None else ('yes' if (r['bricks'], r['index']) == ref else 'NO')
        r['extra'] = r['hwm'] - r['before']
        r['prep_cpu_s'] = r['server_prep_cpu_s'] if r['case'] != 'prep' else r['children_cpu_s']
        if r['case'] != 'prep':
            r['server_rss_growth'] = r['server_rss_peak'] - r['server_rss_before']
    append = args.append and results.with_suffix('.csv').exists()
    with open(results.with_suffix('.csv'), 'a' if append else 'w', newline='') as f:
        w = csv.writer(f, lineterminator='\n')
        if not append:
            w.writerow(columns)
        for r in rows:
            g = r.get
            w.writerow([args.label, r['n'], mb(r['array_bytes']), r['round'], r['case'], r['name'],
                        g('chunk_bytes', ''), r['chunks'] or '', s(r['wall_s']), s(r['cpu_s']), mb(r['before']),
                        mb(r['hwm']), mb(r['extra']), s(g('send_s')), s(g('write_s')), s(g('server_total_s')),
                        s(g('transfer_s')), s(r['prep_s']), s(r['prep_child_s']), mb(r['prep_hwm']),
                        s(r['prep_cpu_s']), r['faults'], s(g('server_cpu_s')), g('server_faults', ''),
                        mb(g('server_rss_before')),
                        mb(g('server_rss_growth')), mb(r['store_bytes']), r['bricks'], r['index'], r['same']])

    def median(n, case, key):
        values = [r[key] for r in rows if r['n'] == n and r['case'] == case and r.get(key) is not None]
        return statistics.median(values) if values else None

    title = 'Arrays to a server: `client.upload` against `voxbrick.prep`' + (f': {args.label}' if args.label else '')
    dirty = f' with changes ({", ".join(changed[:8])}{", ..." if len(changed) > 8 else ""})' if changed else ''
    lines = [
        f'{"##" if append else "#"} {title}',
        '',
        f'{started:%Y-%m-%d %H:%M} UTC, commit {commit}{dirty}. Machine: {os.cpu_count()}-core virtual machine '
        f'({cpu}, {mem / 2**30:.0f} GiB), shared with other work (load average {load_start[0]:.1f} at the start, '
        f'{load_end[0]:.1f} at the end); no rendering here, so its GL renderer (llvmpipe) plays no part. Everything '
        f'under `nice`. `voxbrick` from `{os.path.relpath(args.exe, SOURCE_DIR)}`, the package from '
        f'`{os.path.relpath(args.package, SOURCE_DIR)}`, Python {platform.python_version()} (`{sys.executable}`).',
        '',
        f'Command: `{command}`',
        '',
        'The array: N³ float32 Gaussian blobs (8, smooth) made with NumPy, loaded whole into each case\'s own fresh '
        'Python process (a C-contiguous ndarray, axes z, y, x): the process\'s resident set before the call holds '
        'it (N³·4 bytes) besides Python, NumPy and the package. Cases: `prep` is `voxbrick.prep(array, out)` on this '
        'machine (the same work without a server: a raw file written, then `voxbrick prep`); `tcp-1m` '
        '`client.upload` over TCP to a server with the default 1 MiB message limit; `tcp-16m` the same to a second '
        f'server started with `--max-message-bytes {BIG_MESSAGES}`; `ws-1m` over the first server\'s WebSocket (the '
        'HTTP port). Both servers: `voxbrick serve --no-config --http-token T --upload-max-mb 2048 '
        f'--render-threads 1`, on this machine (loopback). {args.rounds} rounds per size, the cases alternating '
        '(the order rotated each round); medians below, every run in `upload.csv`.',
        '',
        'Columns: **wall**, the call (prep() or upload(); the connection is made before it); **Python before** '
        'its resident set just before the call, **peak** its VmHWM during the call (reset just before it through '
        '`/proc/self/clear_refs`), **+call** the difference: the call\'s own memory; **client CPU** the Python '
        'process\'s CPU time in the call and its minor page faults (pages first touched); **client sent** the call\'s start to its last chunk handed to the socket. '
        'For an upload the server\'s side, from its log\'s millisecond timestamps '
        '("upload \'NAME\' of B bytes started": the Upload arrived; "... prepped into": the store in place) and the '
        'moment its `voxbrick prep` child was forked (its start time in /proc/PID/stat, 10 ms ticks: all chunks had '
        'arrived): **transfer** = started → prep child, **prep** = prep child → prepped into; **server CPU** the server\'s own '
        'CPU time in the run (receiving and writing the chunks, its prep child\'s excluded) and minor page faults, **server RSS +** the '
        'growth of its resident set. For the local `prep`, **transfer** is the raw file\'s writing (the call\'s '
        'start → the prep child) and **prep** the child to the call\'s end. **prep child** its lifetime as seen by polling /proc '
        'every 20 ms, its peak (VmHWM, sampled as often) and CPU time. **store**: bricks.bin and index.bin digested and compared with the local '
        'prep\'s of the same array.',
    ]
    for n in sizes:
        size = n ** 3 * 4
        lines += ['', f'### N = {n}: {size / MiB:.0f} MiB of voxels' +
                  (f' (the array made in {fills[n]:.1f} s)' if fills.get(n) else ''), '',
                  '| case | chunks | **wall** | Python before | peak | **+call** | client CPU (page faults) | client sent '
                  '| transfer | prep | server CPU (page faults) | server RSS + | prep child: s, peak, CPU '
                  '| store same as prep\'s |',
                  '| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |']
        for case in cases:
            these = [r for r in rows if r['n'] == n and r['case'] == case]
            if not these:
                continue
            m = lambda key: median(n, case, key)  # noqa: E731
            chunks = '' if case == 'prep' else f'{m("chunks"):.0f} × {these[0]["chunk_bytes"] / MiB:.0f} MiB'
            transfer = m('write_s') if case == 'prep' else m('transfer_s')
            same = sorted({r['same'] for r in these})
            lines.append(
                f'| {case} | {chunks} | **{m("wall_s"):.2f} s** | {mb(m("before"))} MB | {mb(m("hwm"))} MB | '
                f'**{mb(m("extra"))} MB** | {m("cpu_s"):.2f} s ({m("faults"):.0f}) | '
                + ('— | ' if case == 'prep' else f'{m("send_s"):.2f} s | ')
                + f'{transfer:.2f} s | {m("prep_s"):.2f} s | '
                + (f'{m("server_cpu_s"):.2f} s ({m("server_faults"):.0f}) | {mb(m("server_rss_growth"))} MB | '
                   if case != 'prep' else '— | — | ')
                + f'{m("prep_child_s"):.2f} s, {mb(m("prep_hwm"))} MB, {m("prep_cpu_s"):.2f} s | '
                f'{"/".join(same) or "—"} (`{these[0]["bricks"]}`) |')
        lines += ['', 'Every run (wall s, transfer s, prep s, +call MB):', '']
        for case in cases:
            these = [r for r in rows if r['n'] == n and r['case'] == case]
            if these:
                lines.append(f'- {case}: ' + '; '.join(
                    f'{r["wall_s"]:.2f} / {r.get("transfer_s", r.get("write_s")):.2f} / {r["prep_s"]:.2f} / '
                    f'{mb(r["extra"])}' for r in these))
    lines.append('')
    with open(results.with_suffix('.md'), 'a' if append else 'w') as f:
        f.write(('\n' if append else '') + '\n'.join(lines))
    print('\n'.join(lines))


if __name__ == '__main__':
    main()
