"""HTTPS in front of a plain HTTP server, for tests/dicomweb (Debian's Orthanc 1.10 closes its own TLS connections
with a reset): accepts TLS connections on a free loopback port, with CERT and KEY, and forwards each connection's
bytes to 127.0.0.1:TARGET and back. Writes the port it listens on, then a newline, to PORT_FILE.

  tls_forward.py CERT KEY TARGET PORT_FILE
"""
import os
import socket
import ssl
import sys
import threading


def pipe(source, sink):
    try:
        while True:
            data = source.recv(65536)
            if not data:
                break
            sink.sendall(data)
    except OSError:
        pass
    finally:
        for s in (source, sink):
            try:
                s.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass


def serve(client, context, target):
    try:
        tls = context.wrap_socket(client, server_side=True)
    except (ssl.SSLError, OSError):  # a client that refused the certificate
        client.close()
        return
    try:
        upstream = socket.create_connection(("127.0.0.1", target))
    except OSError:
        tls.close()
        return
    threading.Thread(target=pipe, args=(upstream, tls), daemon=True).start()
    pipe(tls, upstream)


def main():
    cert, key, target, port_file = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
    context = ssl.SSLContext(ssl.PROTOCOL_TLS_SERVER)
    context.load_cert_chain(cert, key)
    listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    listener.bind(("127.0.0.1", 0))
    listener.listen(16)
    with open(port_file + ".tmp", "w") as f:
        f.write("%d\n" % listener.getsockname()[1])
    os.replace(port_file + ".tmp", port_file)
    while True:
        client, _ = listener.accept()
        threading.Thread(target=serve, args=(client, context, target), daemon=True).start()


if __name__ == "__main__":
    main()
