#!/usr/bin/env python3
"""mcpt view under mpirun: one image on every rank's device. Rank 0 serves the page and its
state lists each rank's share; pause stops every rank (no rank takes a chunk while paused);
reset starts the image over on all of them; Ctrl-C (mpirun passes it on) ends every rank,
rank 0 printing each one's share. An A/B view under mpirun is refused, and so is a rank
started for another job.
Usage: view_mpi_test.py MCPT_BINARY (exit 77: no mpirun)"""
import http.client
import json
import os
import shutil
import signal
import subprocess
import sys
import time

from view_util import start_view

MCPT = sys.argv[1]
RANKS = 3
failures = []


def check(ok, what):
    print(("ok    " if ok else "FAIL  ") + what, flush=True)
    if not ok:
        failures.append(what)


def mpirun(ranks):
    return ["mpirun", "--oversubscribe", "-np", str(ranks)]


def request(port, token, path, method="GET"):
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
    conn.request(method, path, body=b"" if method == "POST" else None,
                 headers={"X-MCPT-Token": token})
    r = conn.getresponse()
    data = r.read()
    conn.close()
    return r.status, data


def side(port, token):
    return json.loads(request(port, token, "/api/state")[1])["sides"][0]


def chunks(s):
    return [d["chunks"] for d in s["devices"]]


def wait_for(port, token, what, ok, limit_s=120):
    """Polls the state until ok(side) holds; the side then (None on time out)."""
    deadline = time.time() + limit_s
    while time.time() < deadline:
        s = side(port, token)
        if ok(s):
            return s
        time.sleep(0.1)
    check(False, what + " within %d s" % limit_s)
    return None


def every_rank_rendering(s):
    return len(s["devices"]) == RANKS and all(c > 0 for c in chunks(s)) and s["spp"] > 0


def main():
    if shutil.which("mpirun") is None:
        print("skipped: no mpirun (openmpi-bin)")
        return 77
    os.environ.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
                      OMPI_MCA_rmaps_base_oversubscribe="1")

    # An A/B view: refused, with the reason.
    r = subprocess.run(mpirun(2) + [MCPT, "view", "--a", "opencl", "--b", "opencl", "--width",
                                    "8", "--height", "8", "--time", "1", "--port", "0"],
                       capture_output=True, text=True, timeout=120)
    check(r.returncode != 0 and "an A/B view runs in one process" in r.stdout + r.stderr,
          "an A/B view under mpirun is refused (status %d)" % r.returncode)

    # A rank started for another job (another seed): refused at once, named.
    r = subprocess.run(mpirun(1) + [MCPT, "view", "cornell", "--width", "8", "--height", "8",
                                    "--time", "60", "--port", "0", "--seed", "1", ":", "-np",
                                    "1", MCPT, "view", "cornell", "--width", "8", "--height",
                                    "8", "--time", "60", "--port", "0", "--seed", "2"],
                       capture_output=True, text=True, timeout=120)
    out = r.stdout + r.stderr
    check(r.returncode != 0 and "rank 1" in out and "was started for another job: seed 2" in out,
          "a rank of another job (seed 2) is refused, named (status %d)" % r.returncode)

    proc, port, url = start_view(MCPT, ["cornell", "--width", "32", "--height", "24", "--time",
                                        "300"], launcher=mpirun(RANKS))
    token = url.split("token=")[1]
    try:
        # Every rank takes chunks of the one image; the state names the ranks.
        s = wait_for(port, token, "every rank renders", every_rank_rendering)
        if s:
            names = [d["name"] for d in s["devices"]]
            check(all(any("(rank %d)" % k in n for n in names) for k in range(1, RANKS)),
                  "the state names ranks 1-%d: %s" % (RANKS - 1, names))
        # How long a step takes here, from the run itself: the longest time between three
        # successive changes of the count (so the waits below hold on any machine's speed).
        changes, last = [], side(port, token)["spp"]
        deadline = time.time() + 120
        while len(changes) < 3 and time.time() < deadline:
            spp = side(port, token)["spp"]
            if spp != last:
                changes.append(time.time())
                last = spp
            time.sleep(0.05)
        step = max(b - a for a, b in zip(changes, changes[1:])) if len(changes) == 3 else 10.0
        # Paused: once the step under way has ended (nothing moves for two steps' time), no
        # device takes a chunk and none renders for another step and a half. Load cannot fake a
        # change: spp and chunks move only when a step ends, and a step is the session's own 2 s
        # round (round_seconds) plus chunks of <= 0.5 s at the speed just measured, so the step
        # under way outlasts 2 steps + 0.5 s (>= 4.5 s) only if its last chunks run several
        # times slower than seconds before; while paused no round runs: no rank gets a chunk.
        request(port, token, "/api/pause", "POST")
        last, still_since = None, time.time()
        deadline = time.time() + 120
        while time.time() - still_since < 2 * step + 0.5 and time.time() < deadline:
            s = side(port, token)
            now = (s["spp"], chunks(s))
            if now != last:
                last, still_since = now, time.time()
            time.sleep(0.1)
        time.sleep(1.5 * step + 0.5)
        after = side(port, token)
        check(last is not None and (after["spp"], chunks(after)) == last,
              "paused: no rank takes a chunk (spp and chunks %s, then %s)" %
              (last, (after["spp"], chunks(after))))
        # Reset (running): the image starts over, on every rank again.
        request(port, token, "/api/resume", "POST")
        before = wait_for(port, token, "rendering again after resume",
                          lambda s: s["spp"] > after["spp"])
        if before:
            request(port, token, "/api/reset", "POST")
            again = wait_for(port, token, "the image starts over after reset",
                             lambda s: 0 < s["spp"] < before["spp"])
            check(again is not None, "after reset the image starts over (%s spp, then %s)" %
                  (before["spp"], again["spp"] if again else "-"))
            s = wait_for(port, token, "every rank renders after reset", every_rank_rendering)
            check(s is not None, "every rank takes chunks after reset")
    finally:
        # Ctrl-C, as a user at the terminal: mpirun passes it on to every rank.
        proc.send_signal(signal.SIGINT)
        try:
            out, _ = proc.communicate(timeout=60)
        except subprocess.TimeoutExpired:
            proc.kill()
            out, _ = proc.communicate()
            check(False, "the job ends within 60 s of Ctrl-C")
    shares = [line for line in out.splitlines() if line.strip().startswith("device ")]
    check(len(shares) == RANKS and all(" chunks, " in line for line in shares),
          "rank 0 prints every rank's share at the end:\n" + "\n".join(shares))
    if failures:
        print("%d check(s) failed" % len(failures))
        print(out[-3000:])
        return 1
    print("all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
