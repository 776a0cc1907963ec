"""The package against a real `voxbrick serve` over TLS with tokens scoped to datasets: certificates made here by
Debian's `openssl` (a test CA, a server certificate naming 127.0.0.1, and a self-signed one), both transports inside
TLS ("tls://" and "wss://" / "https://"), the server's certificate verified, a token presented over TCP by
Authenticate (protocol version 5) and over the WebSocket by its upgrade, and the refusals named."""
from __future__ import annotations

import hashlib
from pathlib import Path

import pytest

import voxbrick
from conftest import Server, largest_difference
from voxbrick.errors import ErrorCode

RADIOLOGY = 'radiology-Secret_1'  # opens mri.vbs only
SPARSE = 'sparse-Secret_2'  # opens sparse only
SCENE = dict(camera=(30, 20), tf='mri', size=(64, 48))


@pytest.fixture(scope='module')
def tls_server(datasets: Path, work: Path, certs: Path):
    """A server speaking TLS on both ports, with two tokens of the configuration, each opening one dataset."""
    own = work / 'tls-server'
    own.mkdir()
    config = own / 'server.toml'
    sha = lambda secret: hashlib.sha256(secret.encode()).hexdigest()  # noqa: E731 (as `voxbrick token` writes it)
    config.write_text(f'[tls]\ncert = "{certs / "server.pem"}"\nkey = "{certs / "server.key"}"\n\n'
                      f'[[tokens]]\nid = "radiology"\nsha256 = "{sha(RADIOLOGY)}"\ndatasets = ["mri.vbs"]\n\n'
                      f'[[tokens]]\nid = "sparse"\nsha256 = "{sha(SPARSE)}"\ndatasets = ["sparse"]\n')
    s = Server(datasets, own, extra=('--config', str(config)), token=None)
    yield s
    s.stop()


def test_both_transports_inside_tls_verify_the_server_and_carry_the_token(server, tls_server, certs):
    ca = str(certs / 'ca.pem')
    with voxbrick.connect(server.address) as plain:
        expected = plain.render('mri.vbs', **SCENE)
    # TCP inside TLS: the token presented by Authenticate after Hello; the server names it.
    with voxbrick.connect(f'tls://127.0.0.1:{tls_server.port}', token=RADIOLOGY, ca=ca) as c:
        assert c.version == 9 and c.session.token_id == 'radiology'
        assert c.datasets() == ['mri.vbs']
        assert largest_difference(c.render('mri.vbs', **SCENE), expected) <= 1
        assert repr(c).startswith(f'<voxbrick.Client tls://127.0.0.1:{tls_server.port} version 9')
    # The WebSocket over TLS: wss://, or the viewer's https:// address with its token.
    for address, token in [(f'wss://127.0.0.1:{tls_server.http_port}', SPARSE),
                           (f'https://127.0.0.1:{tls_server.http_port}/?token={SPARSE}', None)]:
        with voxbrick.connect(address, token=token, ca=ca) as c:
            assert c.datasets() == ['sparse']
            assert c.render('sparse', size=(32, 32)).shape == (32, 32, 4)


def test_a_certificate_the_client_cannot_trust_is_refused_by_name(tls_server, certs):
    tcp = f'tls://127.0.0.1:{tls_server.port}'
    # Signed by a CA the client was not given (the system's CAs do not know the test CA).
    with pytest.raises(voxbrick.TlsError, match=r'certificate of the server at 127\.0\.0\.1:\d+ did not verify'):
        voxbrick.connect(tcp, token=RADIOLOGY)
    with pytest.raises(voxbrick.TlsError, match='did not verify'):
        voxbrick.connect(tcp, token=RADIOLOGY, ca=str(certs / 'other.pem'))
    # The right CA, but a name the certificate does not carry (it names 127.0.0.1 alone).
    with pytest.raises(voxbrick.TlsError, match="did not verify: Hostname mismatch"):
        voxbrick.connect(f'wss://localhost:{tls_server.http_port}', token=SPARSE, ca=str(certs / 'ca.pem'))
    # insecure takes any certificate (the link encrypted, the server's identity not checked).
    with voxbrick.connect(tcp, token=RADIOLOGY, insecure=True) as c:
        assert c.datasets() == ['mri.vbs']


def test_tokens_are_scoped_and_a_wrong_one_is_forbidden(tls_server, certs):
    ca = str(certs / 'ca.pem')
    tcp = f'tls://127.0.0.1:{tls_server.port}'
    with voxbrick.connect(tcp, token=SPARSE, ca=ca) as c:
        assert c.datasets() == ['sparse']
        with pytest.raises(voxbrick.ServerError) as e:
            c.info('mri.vbs')
        assert e.value.code == ErrorCode.UnknownDataset  # the words of a dataset that does not exist
    with pytest.raises(voxbrick.ServerError) as e:
        voxbrick.connect(tcp, token='not-a-Token', ca=ca)
    assert e.value.code == ErrorCode.Forbidden
    # Without a token a session sees nothing: the server has [[tokens]] and no anonymous datasets.
    with voxbrick.connect(tcp, ca=ca) as c:
        assert c.datasets() == []
    with pytest.raises(voxbrick.ConnectionRefused) as e:
        voxbrick.connect(f'wss://127.0.0.1:{tls_server.http_port}', token='not-a-Token', ca=ca)
    assert e.value.status == 403


def test_the_wrong_kind_of_connection_is_told_why(server, tls_server, certs):
    # A client in the clear on the TLS port: the server answers in the clear that it speaks TLS.
    with pytest.raises(voxbrick.ServerError, match='TLS'):
        voxbrick.connect(f'127.0.0.1:{tls_server.port}')
    # A TLS client on a plain port.
    with pytest.raises(voxbrick.TlsError, match='TLS handshake with the server at 127.0.0.1'):
        voxbrick.connect(f'tls://127.0.0.1:{server.port}', insecure=True)
    with pytest.raises(ValueError, match='ca= and insecure= are for TLS'):
        voxbrick.connect(server.address, ca=str(certs / 'ca.pem'))
    with pytest.raises(ValueError, match='a token over TCP needs protocol version 5'):
        voxbrick.connect(f'tls://127.0.0.1:{tls_server.port}', token=RADIOLOGY, max_version=4,
                         ca=str(certs / 'ca.pem'))
