"""What the Python package's tests share: the voxbrick binary, small datasets made with the real `voxbrick prep`
(the MRI template and a synthetic field) and one real `voxbrick serve` process on free ports, with an HTTP port and an
access token. ctest passes the binary as $VOXBRICK_EXE; the package comes from python/ of this source tree."""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

SOURCE_DIR = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(SOURCE_DIR / 'python'))

MRI = Path('/usr/share/mricron/templates/ch2better.nii.gz')
TOKEN = 'py-Test_token.1'


def voxbrick_exe() -> str:
    exe = os.environ.get('VOXBRICK_EXE') or os.environ.get('VOXBRICK') or str(SOURCE_DIR / 'build' / 'voxbrick')
    if not os.access(exe, os.X_OK):
        raise RuntimeError(f'no voxbrick binary at {exe}: build it, or set VOXBRICK_EXE')
    return exe


def run_voxbrick(*args: str) -> subprocess.CompletedProcess:
    """Runs `voxbrick ARGS`; fails the test with its output when it fails."""
    result = subprocess.run([voxbrick_exe(), *args], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    assert result.returncode == 0, f'voxbrick {" ".join(args)} failed ({result.returncode}): {result.stdout}'
    return result


class Server:
    """A real `voxbrick serve` over `datasets`: TCP on `address`, HTTP (viewer, WebSocket) on `http_port`, with the
    access token `token` (none: the configuration's tokens, if any). `extra` may name a configuration file
    (`--config`); without one none is read."""

    def __init__(self, datasets: Path, work: Path, extra: tuple = (), token: str = TOKEN):
        for name in ('port', 'http-port'):
            (work / name).unlink(missing_ok=True)
        self.log = work / 'serve.log'
        config = [] if '--config' in extra else ['--no-config']
        with open(self.log, 'w') as log:
            self.process = subprocess.Popen(
                [voxbrick_exe(), 'serve', *config, '--datasets', str(datasets), '--port', '0', '--port-file',
                 str(work / 'port'), '--http', '0', '--http-port-file', str(work / 'http-port'),
                 *(['--http-token', token] if token else []), '--render-threads', '1', *extra],
                stdout=log, stderr=subprocess.STDOUT)
        deadline = time.monotonic() + 60
        while True:
            ports = [work / 'port', work / 'http-port']
            if all(p.exists() and p.read_text().strip() for p in ports):
                break
            if self.process.poll() is not None or time.monotonic() > deadline:
                self.stop()
                raise RuntimeError(f'the server did not start: {self.log.read_text()}')
            time.sleep(0.02)
        self.port = int((work / 'port').read_text())
        self.http_port = int((work / 'http-port').read_text())
        self.address = f'127.0.0.1:{self.port}'
        self.ws = f'ws://127.0.0.1:{self.http_port}'
        self.viewer = f'http://127.0.0.1:{self.http_port}'

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()


@pytest.fixture(scope='session')
def work(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp('voxbrick-python')


@pytest.fixture(scope='session')
def datasets(work: Path) -> Path:
    """mri.vbs (the MRI template, u8, 301x370x316), sparse (a synthetic field, 32^3), cold (sparse again, opened
    by one test only, so its bricks are not in the server's memory) and fresh-0 ... fresh-3 (mri.vbs again, each
    drawn once, see fresh())."""
    assert MRI.exists(), f'{MRI} is missing: install the mricron-data package (scripts/setup.sh)'
    directory = work / 'datasets'
    directory.mkdir()
    run_voxbrick('prep', str(MRI), '--no-vdb', '-q', '-o', str(directory / 'mri.vbs'))
    run_voxbrick('prep', 'synthetic:sparse,n=32', '--brick', '16', '--no-vdb', '-q', '-o', str(directory / 'sparse'))
    shutil.copytree(directory / 'sparse', directory / 'cold')
    for i in range(FRESH):
        shutil.copytree(directory / 'mri.vbs', directory / f'fresh-{i}', copy_function=os.link)
    return directory


FRESH = 4
_fresh_taken = []


def fresh() -> str:
    """The name of a copy of mri.vbs no frame has been drawn of yet. Byte-equal frames need one: the server draws a
    frame as `voxbrick render` does, but where a brick lies in the GPU's atlas depends on the frames drawn before,
    and its filtering on that by round-off, within 1/255 (PROTOCOL.md, Session 8); a dataset's first frame on a
    render thread has the atlas of a fresh `voxbrick render`."""
    assert len(_fresh_taken) < FRESH, 'more fresh datasets are needed: raise FRESH'
    _fresh_taken.append(f'fresh-{len(_fresh_taken)}')
    return _fresh_taken[-1]


def largest_difference(a, b) -> int:
    """The largest difference of one channel of two images of the same shape."""
    import numpy as np
    assert a.shape == b.shape
    return int(np.abs(a.astype(int) - b.astype(int)).max())


@pytest.fixture(scope='session')
def server(datasets: Path, work: Path):
    s = Server(datasets, work)
    yield s
    s.stop()


def render_cli(store: Path, scene: dict, out: Path) -> Path:
    """`voxbrick render STORE --scene FILE -o OUT`: the frame the command line draws of `scene`."""
    scene_file = out.with_suffix('.json')
    scene_file.write_text(json.dumps(scene))
    run_voxbrick('render', str(store), '--scene', str(scene_file), '-q', '-o', str(out))
    return out


class Scripted:
    """A transport with a script in place of a server: `answer(header, fields)` gives the messages that answer each
    message sent. No sockets: the session's side of a conversation, message by message."""

    def __init__(self, answer):
        self.answer, self.sent, self.inbox, self.closed = answer, [], [], False

    def send(self, message: bytes) -> None:
        from voxbrick.protocol import decode
        header, fields = decode(message)
        self.sent.append((header.type, header.request_id, fields))
        self.inbox += list(self.answer(header, fields))

    def receive(self, max_body: int):
        from voxbrick.protocol import HEADER, decode_header
        data = self.inbox.pop(0)
        return decode_header(data[:HEADER.size], max_body), data[HEADER.size:]

    def readable(self) -> bool:
        return bool(self.inbox)

    def close(self) -> None:
        self.closed = True


def openssl(*args: str, cwd: Path) -> None:
    result = subprocess.run(['openssl', *args], cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    assert result.returncode == 0, f'openssl {" ".join(args)}: {result.stdout}'


@pytest.fixture(scope='session')
def certs(work: Path) -> Path:
    """ca.pem/ca.key (the test CA), server.pem/server.key (signed by it, for 127.0.0.1 alone) and other.pem (a
    self-signed certificate of another CA, also for 127.0.0.1)."""
    d = work / 'tls'
    d.mkdir()
    ec = ['-newkey', 'ec', '-pkeyopt', 'ec_paramgen_curve:P-256', '-nodes']
    openssl('req', '-x509', *ec, '-days', '2', '-sha256', '-keyout', 'ca.key', '-out', 'ca.pem', '-subj',
            '/CN=voxbrick test CA', cwd=d)
    openssl('req', *ec, '-keyout', 'server.key', '-out', 'server.csr', '-subj', '/CN=127.0.0.1', cwd=d)
    (d / 'san.ext').write_text('subjectAltName = IP:127.0.0.1\n')
    openssl('x509', '-req', '-in', 'server.csr', '-CA', 'ca.pem', '-CAkey', 'ca.key', '-CAcreateserial', '-days', '2',
            '-sha256', '-extfile', 'san.ext', '-out', 'server.pem', cwd=d)
    openssl('req', '-x509', *ec, '-days', '2', '-sha256', '-keyout', 'other.key', '-out', 'other.pem', '-subj',
            '/CN=127.0.0.1', '-addext', 'subjectAltName = IP:127.0.0.1', cwd=d)
    return d
