#!/usr/bin/env python3
"""mcpt view's server without a browser: it serves only its page and API (no file from disk,
whatever the path), survives clients that hang up mid-frame, and refuses bad addresses; it
answers no one without the run's token, no foreign Host (DNS rebinding), no other page's
Origin (CSRF); it bounds request heads, bodies and connections before cpp-httplib parses
them; paused, a frame decoded here (RGBE) and the hover readout match the EXR it saves; a
second viewer on a port in use fails; a scene name that is not UTF-8 does not break the
state; an A/B whose B is fifty times slower shows its maps within seconds, again and again,
and lights them when B's lamps are 5 % brighter; the state's rates are current.
Usage: view_http_test.py MCPT_BINARY"""
import http.client
import json
import math
import os
import shutil
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import time

from view_images import binary_body, read_exr, rgbe_pixel
from view_util import start_view, stop_view

MCPT = sys.argv[1]
failures = []


def check(ok, what):
    print(("ok    " if ok else "FAIL  ") + what, flush=True)
    if not ok:
        failures.append(what)


TOKEN = None  # the running viewer's


def request(port, path, method="GET", headers=None, token=True, body=None):
    """Status, body and headers of one request, sent exactly as written (no client-side
    normalization), with the token in the X-MCPT-Token header unless token is False."""
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
    conn.putrequest(method, path, skip_host=bool(headers and "Host" in headers),
                    skip_accept_encoding=True)
    for k, v in (headers or {}).items():
        conn.putheader(k, v)
    if token:
        conn.putheader("X-MCPT-Token", TOKEN)
    if body is not None:
        conn.putheader("Content-Length", str(len(body)))
    conn.endheaders(body)
    r = conn.getresponse()
    data = r.read()
    conn.close()
    return r.status, data, r.headers


def get(port, path):
    status, body, _ = request(port, path)
    return status, body


def raw(port, data, wait=15):
    """Sends bytes as they are; the first line of the answer (b"" when the server closes)."""
    s = socket.create_connection(("127.0.0.1", port), timeout=wait)
    try:
        s.sendall(data)
        return s.recv(200).split(b"\r\n")[0]
    except OSError as e:
        return str(e).encode()
    finally:
        s.close()


# A 512x512 image: a frame (4 MiB) outlasts the socket buffers, so hanging up mid-frame
# interrupts the server's write.
proc, port, url = start_view(MCPT, ["cornell", "--width", "512", "--height", "512"])
TOKEN = url.split("token=")[1]
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
    # ---- Who may ask: the token, this viewer's Host, no other page's Origin.
    evil = {"Origin": "http://evil.example", "Content-Type": "text/plain"}
    status, _, _ = request(port, "/api/pause", "POST", evil, token=False, body=b"")
    check(status == 403, "a cross-origin POST without the token is refused (%d)" % status)
    status, body = get(port, "/api/state")
    check(status == 200 and json.loads(body)["paused"] is False, "and did not pause the render")
    status, _, _ = request(port, "/api/pause", "POST", evil, body=b"")
    check(status == 403, "a POST from another Origin is refused, token or not (%d)" % status)
    for path in ["/api/state", "/api/save?side=0&format=png", "/"]:
        status, _, _ = request(port, path, token=False)
        check(status == 403, "GET %s without the token: 403 (%d)" % (path, status))
    status, body, _ = request(port, "/api/state", headers={"Host": "evil.example:%d" % port})
    check(status == 403 and b"scene" not in body, "a foreign Host is refused, token or not (%d)" % status)
    status, _, _ = request(port, "/api/state", headers={"Host": "127.0.0.1:1"})
    check(status == 403, "a Host with another port is refused (%d)" % status)
    status, _, _ = request(port, "/api/state", headers={"Sec-Fetch-Site": "cross-site"})
    check(status == 403, "a cross-site fetch is refused (%d)" % status)
    status, _, _ = request(port, "/api/state", token=False, headers={"Cookie": "mcpt_view=" + TOKEN})
    check(status == 200, "the cookie is a token (%d)" % status)
    status, _, _ = request(port, "/api/state?token=" + "0" * 32, token=False)
    check(status == 403, "a wrong token is refused (%d)" % status)
    # Every route with every way of not having the token: 403 (a check that took any
    # non-empty header or cookie, an empty token or a prefix would let one through). POSTs
    # come from the page's own Origin, so only the token is missing.
    origin = {"Origin": "http://127.0.0.1:%d" % port}
    routes = [("GET", "/"), ("GET", "/api/state"), ("GET", "/api/frame?side=0"),
              ("GET", "/api/maps?side=0"), ("GET", "/api/pixel?x=1&y=1"),
              ("GET", "/api/save?side=0&format=png"), ("POST", "/api/pause"),
              ("POST", "/api/resume"), ("POST", "/api/reset")]
    wrong = "0" * 32
    ways = [("none", {}, ""), ("a wrong header", {"X-MCPT-Token": wrong}, ""),
            ("a wrong cookie", {"Cookie": "mcpt_view=" + wrong}, ""),
            ("an empty header", {"X-MCPT-Token": ""}, ""),
            ("an empty cookie", {"Cookie": "mcpt_view="}, ""),
            ("an empty query", {}, "token="),
            ("the header's 31-character prefix", {"X-MCPT-Token": TOKEN[:31]}, ""),
            ("the cookie's prefix", {"Cookie": "mcpt_view=" + TOKEN[:31]}, ""),
            ("the query's prefix", {}, "token=" + TOKEN[:31]),
            ("the token with a character more", {"X-MCPT-Token": TOKEN + "0"}, "")]
    let_through = []
    for method, path in routes:
        for name, headers, query in ways:
            full = path + (("&" if "?" in path else "?") + query if query else "")
            hdrs = dict(headers, **(origin if method == "POST" else {}))
            status, _, _ = request(port, full, method, hdrs, token=False,
                                   body=b"" if method == "POST" else None)
            if status != 403:
                let_through.append("%s %s with %s: %d" % (method, full, name, status))
    check(not let_through, "every route x every way without the token: 403 (%d requests)%s"
          % (len(routes) * len(ways), "; ".join([""] + let_through)))
    status, body = get(port, "/api/state")
    check(status == 200 and json.loads(body)["paused"] is False,
          "and none of the refused POSTs paused the render")
    status, _, _ = request(port, "/api/resume", "POST", {"Cookie": "mcpt_view=" + TOKEN},
                           token=False, body=b"")
    check(status == 403, "a POST with the cookie alone (no Origin) is refused (%d)" % status)
    status, _, _ = request(port, "/api/resume", "POST", {"Cookie": "mcpt_view=" + TOKEN,
                           "Origin": "http://127.0.0.1:%d" % port}, token=False, body=b"")
    check(status == 200, "a POST from the page's own Origin is taken (%d)" % status)
    status, _, hdrs = request(port, "/?token=" + TOKEN, token=False)
    cookie = hdrs.get("Set-Cookie", "")
    check(status == 303 and hdrs.get("Location") == "/" and TOKEN in cookie and
          "HttpOnly" in cookie and "SameSite=Strict" in cookie,
          "the printed address sets the cookie and redirects (%d, %s)" % (status, cookie))
    # ---- Bounds before cpp-httplib parses: head size and lines, bodies, the pace of a head.
    host = b"Host: 127.0.0.1:%d\r\n" % port
    many = b"".join(b"X-%d: y\r\n" % i for i in range(100))
    check(b" 431 " in raw(port, b"GET /api/state HTTP/1.1\r\n" + host + many + b"\r\n"),
          "100 header lines: 431")
    check(b" 431 " in raw(port, b"GET /api/state HTTP/1.1\r\n" + host + b"X: " + b"a" * 20000 + b"\r\n\r\n"),
          "a 20 KB header: 431")
    chunked = b"POST /api/pause HTTP/1.1\r\n" + host + b"Transfer-Encoding: chunked\r\n\r\n5\r\nhello\r\n0\r\n\r\n"
    check(b" 501 " in raw(port, chunked), "a chunked body: 501")
    check(b" 413 " in raw(port, b"POST /api/pause HTTP/1.1\r\n" + host + b"Content-Length: 100000\r\n\r\n"),
          "a 100 KB body: 413")
    # A head sent a byte every 0.5 s: cut at 10 s, while others are still answered. Both bounds
    # are the server's own 10 s head timer (steady clock, started once a worker takes the
    # connection, after the connect): load only delays that pickup and the 408's delivery, and
    # the 2 s below and 4 s above are for those (the slow head itself would take 75 s).
    slow = socket.create_connection(("127.0.0.1", port), timeout=30)
    started = time.time()
    answer = b""
    for i, byte in enumerate(b"GET /api/state HTTP/1.1\r\n" + host + b"X: " + b"a" * 100):
        if i == 3:
            check(get(port, "/api/state")[0] == 200, "others are answered meanwhile")
        try:
            slow.send(bytes([byte]))
        except OSError:
            break
        slow.settimeout(0.5)
        try:
            answer = slow.recv(100)  # the answer, or b"" when closed: either ends the head
            break
        except socket.timeout:
            continue
    took = time.time() - started
    slow.close()
    check(b" 408 " in answer and 8 < took < 14, "a head sent a byte at a time is cut at 10 s "
          "(%.1f s: %r)" % (took, answer[:30]))
    # More connections than threads and queue: the rest are answered 503 at once; afterwards
    # the server serves again. A count, not a time: each of the 8 threads holds an idle one
    # for the 10 s head timeout, so at most 24 are not refused, and the accepting thread writes
    # the 503 before it accepts the next; a refused one is read after at least 16 queued ones
    # timed out (0.2 s each), >= 3.7 s after the last connect, not 0.5 s.
    idle = [socket.create_connection(("127.0.0.1", port), timeout=30) for _ in range(40)]
    time.sleep(0.5)
    refused = 0
    for s in idle:
        s.settimeout(0.2)
        try:
            refused += s.recv(100).startswith(b"HTTP/1.1 503")
        except socket.timeout:
            pass
    for s in idle:
        s.close()
    check(refused >= 40 - 24, "connections beyond 8 served and 16 queued get 503 (%d of 40)" % refused)
    deadline = time.time() + 20
    while time.time() < deadline and get(port, "/api/state")[0] != 200:
        time.sleep(0.5)
    check(get(port, "/api/state")[0] == 200, "and the server answers again")
    # A second viewer on this port: refused, not bound beside it (no SO_REUSEPORT).
    r = subprocess.run([MCPT, "view", "--width", "8", "--height", "8", "--time", "3", "--port",
                        str(port)], capture_output=True, text=True, timeout=120)
    check(r.returncode == 1 and "cannot listen" in r.stderr,
          "a second viewer on the same port fails (exit %d)" % r.returncode)
    # Clients that hang up mid-frame (a reset, not a clean close), twenty times: each with
    # this viewer's Host and the token, so a 200 has begun (a 4 MiB frame) when it hangs up.
    started = 0
    for _ in range(20):
        s = socket.create_connection(("127.0.0.1", port), timeout=30)
        s.sendall(b"GET /api/frame?side=0 HTTP/1.1\r\nHost: 127.0.0.1:%d\r\n"
                  b"X-MCPT-Token: %s\r\n\r\n" % (port, TOKEN.encode()))
        started += s.recv(1000).startswith(b"HTTP/1.1 200")
        s.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
        s.close()
        # And one that disconnects before sending its request in full.
        s = socket.create_connection(("127.0.0.1", port), timeout=30)
        s.sendall(b"GET /api/fr")
        s.close()
    time.sleep(0.5)
    check(started == 20, "each of the 20 frames had begun (200) when its client hung up (%d)"
          % started)
    check(proc.poll() is None, "the server survives clients that hang up mid-frame")
    status, _ = get(port, "/api/state")
    check(status == 200, "and still answers")
finally:
    out = stop_view(proc)
check(proc.returncode == 0, "Ctrl-C ends the viewer with status 0 (%s)" % proc.returncode)
check("frames sent:" in out, "it says what it rendered and sent")


# ---- What the page shows is what the render saves: paused, a frame decoded here (RGBE, then
# the error bytes) and the hover readout (/api/pixel) against the EXR of /api/save, pixel by
# pixel and channel by channel. RGBE keeps 8 bits of mantissa under the largest channel's
# exponent: the decoded (m + 0.5) 2^(E - 136) is within 2^-8 of the largest channel of the
# EXR's value (a swapped channel or an exponent off by one is off by far more). The readout's
# radiance is the EXR's float exactly. Cornell's red and green walls tell the channels apart;
# 80x60, not square, tells rows from columns.
def state_side(port):
    return json.loads(get(port, "/api/state")[1])["sides"][0]


def paused_still(port):
    """Pauses; then waits until the side publishes no new snapshot for 1.5 s (the step under
    way when it paused may still end in one): whether the state says paused, and its side."""
    request(port, "/api/pause", "POST", body=b"")
    get(port, "/api/frame?side=0")  # asks for a snapshot, as the page does
    last, still, deadline = None, 0, time.time() + 60
    while still < 5 and time.time() < deadline:
        state = json.loads(get(port, "/api/state")[1])
        side = state["sides"][0]
        still = still + 1 if (side["serial"], side["spp"]) == last else 0
        last = (side["serial"], side["spp"])
        time.sleep(0.3)
    return state["paused"], side


W, H = 80, 60
proc, port, url = start_view(MCPT, ["cornell", "--width", str(W), "--height", str(H)])
TOKEN = url.split("token=")[1]
try:
    deadline = time.time() + 60
    while time.time() < deadline and state_side(port)["spp"] < 16:
        time.sleep(0.2)
    paused, side = paused_still(port)
    status, body = get(port, "/api/frame?side=0")
    head, data = binary_body(body)
    status_exr, exr, hdrs = request(port, "/api/save?side=0&format=exr")
    name = hdrs.get("Content-Disposition", "")
    ew, eh, ch = read_exr(exr)
    after = state_side(port)
    check(paused and status == 200 and status_exr == 200 and head["width"] == W and head["height"] == H
          and (ew, eh) == (W, H) and len(data) == 5 * W * H and head["serial"] == side["serial"]
          == after["serial"] and head["spp"] == side["spp"] and "%dspp.exr" % head["spp"] in name,
          "paused: the frame (%dx%d, %d spp, serial %d) and the EXR (%dx%d, %s) are of one "
          "snapshot" % (head["width"], head["height"], head["spp"], head["serial"], ew, eh, name))
    exr_px = [[ch[c][i] for c in "RGB"] for i in range(W * H)]
    bad, worst, distinct = [], 0.0, [0, 0]
    for i in range(W * H):
        want, got = exr_px[i], rgbe_pixel(data, i)
        top = max(want)
        tol = 2.0 ** -8 * top * (1 + 1e-6)
        if not all(math.isfinite(v) for v in want):
            ok = data[4 * i + 3] == 255
        elif top <= 1e-32:
            ok = got == [0.0, 0.0, 0.0]
        else:
            ok = all(abs(g - w) <= tol for g, w in zip(got, want))
            worst = max(worst, max(abs(g - w) for g, w in zip(got, want)) / top)
            distinct[0] += abs(want[0] - want[2]) > 8 * tol  # R and B told apart
            distinct[1] += abs(want[1] - want[0]) > 8 * tol  # G and R
        if not ok and len(bad) < 3:
            bad.append("pixel %d,%d: frame %s, EXR %s" % (i % W, i // W, got, want))
        elif not ok:
            bad.append("")
    check(min(distinct) > W * H // 10,
          "the image tells the channels apart (R vs B at %d pixels, G vs R at %d)" % tuple(distinct))
    check(not bad, "the decoded frame matches the EXR within RGBE's 2^-8 of the largest channel "
          "at all %d pixels (worst %.5f; %d off%s)" % (W * H, worst, len(bad),
                                                       ": " + "; ".join(bad[:3]) if bad else ""))
    # The hover readout of a few pixels: the reddest, the greenest, the brightest (the light),
    # the dimmest lit one, the middle, the first and the last; the error byte within a step of
    # the readout's (sum of the channels' standard errors over the sum of their means).
    lit = [i for i in range(W * H) if sum(exr_px[i]) > 0]
    for i in [max(lit, key=lambda i: exr_px[i][0] / sum(exr_px[i])),
              max(lit, key=lambda i: exr_px[i][1] / sum(exr_px[i])),
              max(lit, key=lambda i: sum(exr_px[i])), min(lit, key=lambda i: sum(exr_px[i])),
              H // 2 * W + W // 2, 0, W * H - 1]:
        x, y = i % W, i // W
        status, body = get(port, "/api/pixel?x=%d&y=%d" % (x, y))
        p = json.loads(body)["sides"][0]
        want = exr_px[i]
        rel = sum(p["std_error"]) / sum(want) if sum(want) > 0 else None
        exact_byte = (0 if rel is None else 1 if rel <= 1e-3 else 255 if rel >= 1 else
                      1 + round(254 * (math.log10(rel) + 3) / 3))
        check(p["radiance"] == want and p["spp"] == head["spp"] and
              all(abs(g - w) <= 2.0 ** -8 * max(want) * (1 + 1e-6)
                  for g, w in zip(rgbe_pixel(data, i), want)) and
              abs(data[4 * W * H + i] - exact_byte) <= 1,
              "hover %d,%d: radiance %s = the EXR's %s, the frame's %s, error byte %d (%s)"
              % (x, y, p["radiance"], want, [round(v, 5) for v in rgbe_pixel(data, i)],
                 data[4 * W * H + i], exact_byte))
finally:
    stop_view(proc)

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
# --listen beyond loopback: a warning naming the exposure.
r = subprocess.run([MCPT, "view", "--width", "8", "--height", "8", "--time", "2", "--port", "0",
                    "--listen", "0.0.0.0"], capture_output=True, text=True, timeout=120)
check(r.returncode == 0 and "warning: --listen 0.0.0.0" in r.stderr and "token" in r.stderr,
      "--listen 0.0.0.0 warns (exit %d)" % r.returncode)

# A scene file whose name is not UTF-8: the state is still JSON (the name with U+FFFD).
folder = tempfile.mkdtemp()
try:
    here = os.path.dirname(os.path.abspath(__file__))
    odd = os.path.join(os.fsencode(folder), b"\xff\xfe-scene.gltf")
    shutil.copy(os.path.join(here, "..", "data", "emissive_triangle.gltf"), odd)
    proc, port, url = start_view(MCPT, [os.fsdecode(odd), "--width", "16", "--height", "16"])
    TOKEN = url.split("token=")[1]
    try:
        time.sleep(1)
        status, body = get(port, "/api/state")
        ok = status == 200
        try:
            state = json.loads(body)
        except ValueError:
            ok = False
        check(ok and "\ufffd" in state["scene"], "a scene name that is not UTF-8 (%d)" % status)
    finally:
        stop_view(proc)
finally:
    shutil.rmtree(folder)

# One side on two devices (--device repeated): the state gives each one's share.
dev = next((a for a in os.environ.get("MCPT_TEST_DEVICE_ARGS", "").split() if a.isdigit()), "0")
proc, port, url = start_view(MCPT, ["cornell", "--device", dev, "--device", dev, "--width", "32",
                                    "--height", "32"])
TOKEN = url.split("token=")[1]
try:
    deadline, devices = time.time() + 60, []
    while time.time() < deadline:
        status, body = get(port, "/api/state")
        devices = json.loads(body)["sides"][0]["devices"] if status == 200 else []
        if len(devices) == 2 and all(d["samples"] > 0 for d in devices):
            break
        time.sleep(0.5)
    shares = [d["share"] for d in devices]
    check(len(devices) == 2 and abs(sum(shares) - 1) < 1e-6 and min(shares) > 0,
          "two devices on one side: each one's share (%s)" % shares)
finally:
    stop_view(proc)

# A/B with B fifty times slower (MCPT_VIEW_SLOW_B: B sleeps 49 times each step's time after
# it, as a slow device would): A runs thousands of samples ahead, and still the maps appear
# within seconds and again and again while B climbs to 256 spp, each at a count B reached
# lately (with A's 8 newest milestones kept, no map came before B passed 1160 spp at 10x; at
# 50x none came in 40 s). /api/state gives the current rates: B's shows its slowdown, and A's
# moves from one read to the next (they stayed at the first frame's values before).
def maps_header(port):
    status, body = get(port, "/api/maps")
    if status != 200:
        return None
    n = struct.unpack("<I", body[:4])[0]
    return json.loads(body[4:4 + n])


def slow_b_run(extra, until_b_spp, limit_s):
    """An A/B with B 50x slower, polled every 0.2 s: the maps' headers seen (each with `at`,
    the seconds since B's first samples: the time of the kernel builds before them is the
    machine's, not the viewer's), the last state's sides, and A's rates, one per poll."""
    global TOKEN
    env = dict(os.environ, MCPT_VIEW_SLOW_B="50")
    proc, port, url = start_view(MCPT, ["cornell", "--a", "opencl", "--b", "opencl", "--width",
                                        "24", "--height", "24"] + extra, env=env)
    TOKEN = url.split("token=")[1]
    start, b_start, seen, sides, rates = time.time(), None, [], None, []
    try:
        while time.time() < start + limit_s:
            sides = json.loads(get(port, "/api/state")[1])["sides"]
            if b_start is None and sides[1]["spp"] > 0:
                b_start = time.time()
            rates.append(sides[0]["samples_per_second"])
            h = maps_header(port)
            if h and (not seen or h["spp"] > seen[-1]["spp"]):
                seen.append(dict(h, at=time.time() - (b_start or time.time())))
            if sides[1]["spp"] >= until_b_spp:
                break
            time.sleep(0.2)
    finally:
        stop_view(proc)
    return seen, sides, rates


# Not a race with the machine's speed: B publishes a step only after its sleep (49 times the
# step), and its first step ends at the first milestone (4 spp), which A, not slowed, passed
# long before and keeps (its oldest stays): the maps exist when B's first samples show, so
# `at` is this poll's latency (at most one more B step if that first step fell short of 4).
# The defect (A's oldest milestone dropped) gives no map at all in the run.
MAPS_WITHIN_S = 10
seen, sides, rates = slow_b_run([], 256, 120)
spps = [m["spp"] for m in seen]
check(sides is not None and sides[1]["spp"] >= 256 and sides[0]["spp"] > 20 * sides[1]["spp"]
      and seen and seen[0]["at"] <= MAPS_WITHIN_S and len(seen) >= 4
      and 2 * spps[-1] >= sides[1]["spp"] and all(m["diverged"] == 0 for m in seen),
      "B fifty times slower: the first maps within %d s of B's first samples (at %.1f s), then again and again at "
      "%s spp while B reached %s (A %s), no pixel diverged" %
      (MAPS_WITHIN_S, seen[0]["at"] if seen else -1, spps, sides and sides[1]["spp"],
       sides and sides[0]["spp"]))
ratio = sides[0]["samples_per_second"] / max(sides[1]["samples_per_second"], 1e-9) if sides else 0
check(ratio >= 10 and len(set(rates)) >= 5,
      "current rates: A/B %.0fx (B 50x slowed), A's rate moves (%d distinct of %d reads)" %
      (ratio, len(set(rates)), len(rates)))
# Control: B's lamps 5 % brighter, still 50x slower: the maps light up within the same time.
seen, sides, _ = slow_b_run(["--b-light-scale", "1.05"], 64, 60)
lit = [m for m in seen if m["diverged"] >= 0.9 * m["pixels"]]
check(lit and lit[0]["at"] <= MAPS_WITHIN_S and len(lit) == len(seen),
      "control, B's lamps 5%% brighter and 50x slower: every map lights up, the first within "
      "%d s (%s)" % (MAPS_WITHIN_S, [(m["spp"], m["diverged"], round(m["at"], 1)) for m in seen]))

print("%d failed" % len(failures) if failures else "all passed")
sys.exit(1 if failures else 0)
