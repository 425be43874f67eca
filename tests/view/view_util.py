"""Starting and stopping `mcpt view` for the viewer's tests and scripts/bench-view."""
import re
import signal
import subprocess
import time


def start_view(mcpt, args, timeout=180, env=None, launcher=()):
    """Starts `mcpt view ARGS --port 0` (through `launcher`, e.g. mpirun -np 3); once it
    serves, returns the process, its port and its address with the token
    (http://127.0.0.1:PORT/?token=...)."""
    proc = subprocess.Popen(list(launcher) + [mcpt, "view", "--port", "0"] + args,
                            stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, bufsize=1, env=env)
    deadline = time.time() + timeout
    lines = []
    while time.time() < deadline:
        line = proc.stdout.readline()
        if not line:
            break
        lines.append(line)
        m = re.search(r"mcpt view: (http://127\.0\.0\.1:(\d+)/\?token=([0-9a-f]{32}))", line)
        if m:
            return proc, int(m.group(2)), m.group(1)
    proc.kill()
    raise RuntimeError("mcpt view did not start:\n" + "".join(lines))


def stop_view(proc, timeout=60):
    """Ctrl-C, then the rest of its output."""
    proc.send_signal(signal.SIGINT)
    try:
        out, _ = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, _ = proc.communicate()
    return out
