#!/usr/bin/env python3
"""mcpt view's server without a browser: it serves only its page and API (no file from disk,
whatever the path), survives clients that hang up mid-frame, and refuses bad addresses.
Usage: view_http_test.py MCPT_BINARY"""
import http.client
import json
import signal
import socket
import struct
import subprocess
import sys
import time

from view_util import start_view, stop_view

MCPT = sys.argv[1]
failures = []


def check(ok, what):
    print(("ok    " if ok else "FAIL  ") + what, flush=True)
    if not ok:
        failures.append(what)


def get(port, path):
    """Status and body of GET path, sent exactly as written (no client-side normalization)."""
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
    conn.putrequest("GET", path, skip_host=False, skip_accept_encoding=True)
    conn.endheaders()
    r = conn.getresponse()
    body = r.read()
    conn.close()
    return r.status, body


# A 512x512 image: a frame (4 MiB) outlasts the socket buffers, so hanging up mid-frame
# interrupts the server's write.
proc, port = start_view(MCPT, ["cornell", "--width", "512", "--height", "512"])
try:
    status, body = get(port, "/")
    check(status == 200 and b"mcpt view" in body, "the page is served")
    status, body = get(port, "/api/state")
    check(status == 200 and b'"sides"' in body, "the state is served")
    # Paths outside what the server serves: 404, never a file.
    for path in ["/../../etc/passwd", "/%2e%2e/%2e%2e/etc/passwd", "/api/../../../etc/passwd",
                 "/etc/passwd", "//etc/passwd", "/api/frame/../../../../etc/passwd",
                 "/api/save?side=7&format=exr", "/api/save?side=0&format=../../etc/passwd",
                 "/api/frame?side=../../etc/passwd", "/index.html", "/api"]:
        status, body = get(port, path)
        check(status == 404 and b"root:" not in body, "refused %s (%d)" % (path, status))
    # Wait for the first frame.
    deadline = time.time() + 120
    while time.time() < deadline:
        status, body = get(port, "/api/frame?side=0")
        if status == 200:
            break
        time.sleep(0.5)
    check(status == 200, "a frame is served")
    n = struct.unpack("<I", body[:4])[0]
    check(len(body) == 4 + n + 5 * 512 * 512, "the frame has 5 bytes per pixel (RGBE, error)")
    status, body = get(port, "/api/pixel?x=256&y=256")
    pixel = json.loads(body)["sides"][0] if status == 200 else None
    check(pixel is not None and len(pixel["radiance"]) == 3 and pixel["samples"] > 0,
          "a pixel's values are served: %s" % pixel)
    status, body = get(port, "/api/pixel?x=-1&y=99999")
    check(status == 200 and json.loads(body)["sides"] == [None], "a pixel outside: no values")
    # Clients that hang up mid-frame (a reset, not a clean close), twenty times.
    for _ in range(20):
        s = socket.create_connection(("127.0.0.1", port), timeout=30)
        s.sendall(b"GET /api/frame?side=0 HTTP/1.1\r\nHost: x\r\n\r\n")
        s.recv(1000)
        s.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
        s.close()
        # And one that disconnects before sending its request in full.
        s = socket.create_connection(("127.0.0.1", port), timeout=30)
        s.sendall(b"GET /api/fr")
        s.close()
    time.sleep(0.5)
    check(proc.poll() is None, "the server survives clients that hang up mid-frame")
    status, _ = get(port, "/api/state")
    check(status == 200, "and still answers")
finally:
    out = stop_view(proc)
check(proc.returncode == 0, "Ctrl-C ends the viewer with status 0 (%s)" % proc.returncode)
check("frames sent:" in out, "it says what it rendered and sent")

# Bad addresses: a clear error and a non-zero exit, no server.
for args, expect in [(["--port", "99999"], "port"),
                     (["--listen", "203.0.113.7", "--port", "0"], "cannot listen"),
                     (["--listen", "not-an-address", "--port", "0"], "cannot listen")]:
    r = subprocess.run([MCPT, "view", "--width", "8", "--height", "8", "--time", "5"] + args,
                       capture_output=True, text=True, timeout=120)
    check(r.returncode == 1 and expect in (r.stdout + r.stderr).lower(),
          "refused %s: exit %d, %s" % (" ".join(args), r.returncode,
                                       (r.stderr.strip().splitlines() or [""])[-1]))
# A port already taken.
blocker = socket.socket()
blocker.bind(("127.0.0.1", 0))
blocker.listen(1)
taken = blocker.getsockname()[1]
r = subprocess.run([MCPT, "view", "--width", "8", "--height", "8", "--time", "5", "--port",
                    str(taken)], capture_output=True, text=True, timeout=120)
check(r.returncode == 1 and "cannot listen" in r.stderr, "refused a port in use")
blocker.close()

print("%d failed" % len(failures) if failures else "all passed")
sys.exit(1 if failures else 0)
