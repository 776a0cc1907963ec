"""Runs one mutant through voxbrick for the ingest fuzzer and judges it: exit status (1 for a refusal, 0 only where
the mutant may be valid), no signal, a time bound, the child's peak RSS (wait4's rusage; the child is killed above
a hard cap), one line on stderr naming the input, no leftover output beside the store, and an existing store left
byte for byte as it was by a refused `prep --force`."""

import hashlib
import os
import shutil
import signal
import subprocess
import time
from dataclasses import dataclass, field

HARD_CAP_MB = 2048  # a child above this is killed (and reported); the check is against --rss-limit
RENDER = ["--size", "32x32"]


@dataclass
class Run:
    command: str
    rc: int  # exit status; 128 + signal; -1 when killed for time or memory
    seconds: float
    cpu: float  # user + system seconds: the work done, whatever else loads the machine
    peak_mb: float
    stderr: str
    killed: str = ""  # "time" or "memory" when the runner killed it


@dataclass
class Verdict:
    fmt: str
    label: str
    must: bool
    runs: list = field(default_factory=list)
    outcome: str = ""  # refused, accepted, partly refused (a .vdb or store: one command refused, one not)
    failures: list = field(default_factory=list)


def run_child(argv, env, timeout, stderr_path):
    """Runs argv, polling its RSS; returns a Run."""
    start = time.monotonic()
    with open(stderr_path, "wb") as err:
        p = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=err, env=env)
    killed, peak = "", 0.0
    while True:
        pid, status, usage = os.wait4(p.pid, os.WNOHANG)
        if pid == p.pid:
            break
        try:
            with open(f"/proc/{p.pid}/statm") as f:
                rss_mb = int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20
            peak = max(peak, rss_mb)
        except (OSError, ValueError, IndexError):
            rss_mb = 0
        if not killed and time.monotonic() - start > timeout:
            killed = "time"
        elif not killed and rss_mb > HARD_CAP_MB:
            killed = "memory"
        if killed:
            os.kill(p.pid, signal.SIGKILL)
        time.sleep(0.005)
    p.returncode = 0  # reaped above; keeps Popen from waiting again
    seconds = time.monotonic() - start
    rc = os.waitstatus_to_exitcode(status)
    rc = 128 - rc if rc < 0 else rc
    with open(stderr_path, "rb") as f:
        text = f.read().decode(errors="replace")
    cpu = usage.ru_utime + usage.ru_stime
    return Run(" ".join(argv[1:2]), -1 if killed else rc, seconds, cpu, max(peak, usage.ru_maxrss / 1024.0), text,
               killed)


def tree_hash(root):
    """A digest of every file's path and bytes under root."""
    h = hashlib.sha256()
    for dirpath, dirs, names in os.walk(root):
        dirs.sort()
        for n in sorted(names):
            full = os.path.join(dirpath, n)
            h.update(os.path.relpath(full, root).encode() + b"\0")
            with open(full, "rb") as f:
                h.update(f.read())
    return h.hexdigest()


def message_lines(text):
    """stderr's lines that count: not the GL driver's banner that render prints first, and not the rows of a table
    that follows an error line (indented two spaces: the image series a DICOM folder holds, for --series). Lines end
    at '\n' only (a file's control bytes quoted in a message, such as 0x1c, are not line ends)."""
    lines = [l for l in text.split("\n") if l.strip() and not l.startswith("render: EGL")]
    table = bool(lines) and "--series UID" in lines[0] and lines[0].rstrip().endswith(":")
    return [l for k, l in enumerate(lines) if not (table and k > 0 and l.startswith("  "))]


class Slot:
    """One worker's directory: the mutant's input (in/), a kept store and a kept mesh store (out/) restored from
    the pristine copies whenever a prep replaced them."""

    def __init__(self, root, pristine, env, exe, timeout, rss_limit):
        self.root, self.pristine, self.env, self.exe = root, pristine, env, exe
        self.timeout, self.rss_limit = timeout, rss_limit
        self.inp, self.out = os.path.join(root, "in"), os.path.join(root, "out")
        self.hashes = {k: tree_hash(v) for k, v in pristine.items()}
        os.makedirs(root, exist_ok=True)
        shutil.rmtree(self.out, ignore_errors=True)
        os.makedirs(self.out)
        for name, src in pristine.items():
            shutil.copytree(src, os.path.join(self.out, name))

    def _restore(self, name):
        shutil.rmtree(os.path.join(self.out, name), ignore_errors=True)
        shutil.copytree(self.pristine[name], os.path.join(self.out, name))

    def write_input(self, seed, data):
        shutil.rmtree(self.inp, ignore_errors=True)
        for rel, content in seed.files.items():
            path = os.path.join(self.inp, rel)
            os.makedirs(os.path.dirname(path), exist_ok=True)
            with open(path, "wb") as f:
                f.write(data if rel == seed.target else content)
        return os.path.join(self.inp, seed.arg) if seed.arg else self.inp

    def run(self, args, verdict, must):
        r = run_child([self.exe] + args, self.env, self.timeout, os.path.join(self.root, "stderr"))
        r.command = args[0]
        verdict.runs.append(r)
        fails = verdict.failures
        where = f"{args[0]}: "
        if r.killed:
            fails.append(where + ("hang (over %.0f s)" % self.timeout if r.killed == "time" else "RSS over hard cap"))
        elif r.rc >= 128:
            fails.append(where + f"signal {r.rc - 128}")
        elif r.rc not in (0, 1):
            fails.append(where + f"exit status {r.rc}")
        if r.peak_mb > self.rss_limit:
            fails.append(where + f"peak RSS {r.peak_mb:.0f} MB")
        if r.rc == 1:
            lines = message_lines(r.stderr)
            if len(lines) != 1:
                fails.append(where + f"{len(lines)} lines on stderr")
            if not any(self.inp in l for l in lines):
                fails.append(where + "message does not name the input: " + (lines[0] if lines else "")[:160])
        elif r.rc == 0 and must:
            fails.append(where + "accepted a broken input")
        return r

    def check_out(self, verdict, name):
        """After a refused prep --force: the kept store as it was, nothing else written beside it."""
        leftovers = sorted(set(os.listdir(self.out)) - set(self.pristine))
        if leftovers:
            verdict.failures.append("prep: left output behind: " + ", ".join(leftovers))
            for n in leftovers:
                p = os.path.join(self.out, n)
                shutil.rmtree(p) if os.path.isdir(p) else os.remove(p)
        if tree_hash(os.path.join(self.out, name)) != self.hashes[name]:
            verdict.failures.append("prep: changed the existing store it was refused for")
            self._restore(name)

    def prep(self, arg, verdict, name):
        """prep ARG --force onto the kept store `name`; if it is accepted, the new store must open and render."""
        store = os.path.join(self.out, name)
        r = self.run(["prep", arg, "--force", "-q", "--brick", "8", "-o", store], verdict, verdict.must)
        if r.rc == 0:
            self.run(["info", store], verdict, False)
            self.run(["render", store, *RENDER, "-o", os.path.join(self.root, "frame.png")], verdict, False)
            if verdict.runs[-1].rc != 0 or verdict.runs[-2].rc != 0:
                verdict.failures.append("prep accepted it, but its store does not open")
            self._restore(name)
        else:
            self.check_out(verdict, name)
        return r.rc

    def judge(self, seed, mutant):
        v = Verdict(mutant.fmt, mutant.label, mutant.must)
        arg = self.write_input(seed, mutant.data)
        frame = os.path.join(self.root, "frame.png")
        if seed.kind in ("volume", "vdb"):
            self.prep(arg, v, "kept")
        if seed.kind == "mesh":
            self.prep(arg, v, "kept-mesh")
        if seed.kind == "vdb":
            self.run(["info", arg], v, mutant.must)
            self.run(["render", arg, "--brick", "8", *RENDER, "-o", frame], v, mutant.must)
        if seed.kind in ("store", "meshstore"):
            self.run(["info", arg], v, False)
            self.run(["render", arg, *RENDER, "-o", frame], v, mutant.must)
        combined = seed.kind in ("vdb", "store", "meshstore")  # else the runs after a prep check the store it wrote
        codes = {r.rc for r in (v.runs if combined else v.runs[:1])}
        v.outcome = "refused" if codes == {1} else "accepted" if codes == {0} else "partly refused"
        if any(r.killed or r.rc not in (0, 1) for r in v.runs):
            v.outcome = "crashed or killed"
        return v
