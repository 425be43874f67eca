#!/usr/bin/env python3
"""mcpt view in a real browser: Debian's chromium, headless, driven by selenium.

The page loads, the image updates (its pixels change and the sample count grows), the exposure
and display controls change the displayed pixels, hovering shows a pixel's values; the A/B page
shows both images and a z map that stays white for OpenCL against Vulkan and, for a B whose
light is 3% brighter (the negative control), lights up where the light is and shows the bias
on the noisy pixels at the size their noise predicts; the page's false colours (zColor,
sequentialColor) are the C++ ones (common/io/false_color.cpp) byte for byte, over C++ output
of `mcpt compare --report` and `mcpt converge --report` and the C++ unit test's own cases.
Exits 77 (skipped) where chromium, chromedriver or selenium is not installed.
Usage: view_browser_test.py MCPT_BINARY; MCPT_VIEW_SCREENSHOTS=DIR also writes the pages'
screenshots there (docs/view.png, docs/view-ab.png) at a larger size."""
import math
import os
import re
import shutil
import struct
import subprocess
import sys
import tempfile
import time

from view_images import read_exr, report_images
from view_util import start_view, stop_view

MCPT = sys.argv[1]
SHOTS = os.environ.get("MCPT_VIEW_SCREENSHOTS")
try:
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By
except ImportError:
    print("SKIP: python3-selenium is not installed (scripts/install-deps --tests)")
    sys.exit(77)
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
DRIVER = shutil.which("chromedriver")
if not CHROMIUM or not DRIVER:
    print("SKIP: chromium and chromium-driver are not installed (scripts/install-deps --tests)")
    sys.exit(77)

failures = []


def check(ok, what):
    print(("ok    " if ok else "FAIL  ") + what, flush=True)
    if not ok:
        failures.append(what)


def browser():
    opts = Options()
    opts.binary_location = CHROMIUM
    for a in ["--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
              "--window-size=1300,%d" % (1900 if SHOTS else 1500)]:
        opts.add_argument(a)
    return webdriver.Chrome(service=Service(DRIVER), options=opts)


def wait_for(drv, script, what, timeout=240):
    """Polls a JavaScript expression until it is true; a test failure if it never is."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        if drv.execute_script("return " + script):
            return True
        time.sleep(0.2)
    check(False, "timed out waiting for " + what)
    raise SystemExit(1)


# The displayed pixels of a canvas: a checksum, the mean of R+G+B, and how many pixels a z map
# shows in full colour (|z| >= 4: a channel at most 20% of 255).
CANVAS = """
const c = document.getElementById(arguments[0]);
const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
let hash = 0, sum = 0, hot = 0;
for (let i = 0; i < d.length; i += 4) {
  hash = (hash * 31 + d[i] * 7 + d[i + 1] * 3 + d[i + 2]) % 1000000007;
  sum += d[i] + d[i + 1] + d[i + 2];
  if (Math.min(d[i], d[i + 1], d[i + 2]) <= 51) hot++;
}
return {w: c.width, h: c.height, hash: hash, mean: sum / (d.length / 4), hot: hot / (d.length / 4)};
"""
# The z map where A's image is brightest (the light seen directly, without noise: pixels
# partly covered by its edge have sampling noise): full colour there?
AT_LIGHT = """
const f = window.mcptView.frames[0], m = window.mcptView.maps;
const lum = i => radianceAt(f, i).reduce((a, b) => a + b, 0);
let max = 0;
for (let i = 0; i < f.width * f.height; i++) max = Math.max(max, lum(i));
let n = 0, hot = 0;
for (let i = 0; i < f.width * f.height; i++)
  if (lum(i) > 0.99 * max) {
    n++;
    if (m.data[2 * i] >= 4) hot++;
  }
return {pixels: n, hot: n ? hot / n : 0};
"""
# The z map on the noisy pixels (lit, not the light: A's R+G+B between 0 and half its largest;
# an error byte between 0.1% and 100%), for a B whose lamps are `scale` times brighter. Same
# seed, so B = scale A sample by sample, and each pixel's z = (B - A) / sqrt(seA^2 + seB^2) is
# (scale - 1) / (sqrt(1 + scale^2) e), e = seA / A its relative error, the error byte's: the
# median z, and the median of z over that prediction.
NOISY = """
const f = window.mcptView.frames[0], m = window.mcptView.maps, scale = arguments[0];
const n = f.width * f.height, lum = i => radianceAt(f, i).reduce((a, b) => a + b, 0);
let max = 0;
for (let i = 0; i < n; i++) max = Math.max(max, lum(i));
const k = (scale - 1) / Math.sqrt(1 + scale * scale), z = [], ratio = [];
for (let i = 0; i < n; i++) {
  const l = lum(i), e = f.bytes[4 * n + i];
  if (!(l > 0 && l < 0.5 * max) || e <= 1 || e === 255 || !Number.isFinite(m.data[2 * i]))
    continue;
  z.push(m.data[2 * i]);
  ratio.push(m.data[2 * i] / (k / Math.pow(10, 3 * (e - 1) / 254 - 3)));
}
const median = a => a.sort((x, y) => x - y)[a.length >> 1];
return {pixels: z.length, of: n, z: median(z), ratio: median(ratio)};
"""


def canvas(drv, name):
    return drv.execute_script(CANVAS, name)


def shoot(drv, name):
    if SHOTS:
        drv.save_screenshot(os.path.join(SHOTS, name))
        print("wrote " + os.path.join(SHOTS, name))


# ---- The C++ false colours (common/io/false_color.cpp), for the page's JavaScript copy to
# match byte for byte: z_color() from `mcpt compare` (its report's Welch z map, its -o EXR's
# z in G: float inputs from B darker (z far below -5) to brighter (far above 5), and 0 where a
# pixel says nothing); sequential_color(log_unit(x, 1e-4, 1)) from `mcpt converge`'s error map
# against a reference cached here and then rewritten (the pixels the final image leaves black
# at --max-depth 0 give x = sum|ref| / (sum ref + 0.03) of the means written: t from -0.25 to
# past 1, 0, negative, NaN and infinite x); and the C++ unit test's own cases (the stops, the
# ends, -0, +-infinity, NaN), which the FalseColor unit suite checks against the C++.
HERE = os.path.dirname(os.path.abspath(__file__))


def f32(v):
    """v rounded to a float, as C++'s float(v) (infinite beyond its range)."""
    try:
        return struct.unpack("<f", struct.pack("<f", v))[0]
    except OverflowError:
        return math.copysign(math.inf, v)


def cpp_false_colors():
    """[(function, input, C++ RGB)] ('z': z_color, 's': sequential_color), and how many of
    them the unit test's source gave."""
    cases = []
    tmp = tempfile.mkdtemp()
    # The reference cache here, never the user's; the drivers' kernel caches (pocl, mesa) the
    # user's, linked (without them the kernels compile again: seconds).
    user_cache = os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache")
    for name in os.listdir(user_cache) if os.path.isdir(user_cache) else []:
        if name != "mcpt":
            os.symlink(os.path.join(user_cache, name), os.path.join(tmp, name))
    env = dict(os.environ, XDG_CACHE_HOME=tmp)
    try:
        w, h = 32, 24
        small = ["--width", str(w), "--height", str(h)]
        # sequential_color: a reference cached by a first converge, rewritten, read by a second.
        conv = [MCPT, "converge", "cornell", "--spp", "1", "--time", "60", "--max-depth", "0",
                "--reference", "cached", "--reference-spp", "16", "-o", tmp + "/conv"] + small
        r = subprocess.run(conv, capture_output=True, text=True, env=env, timeout=300)
        m = re.search(r"into (\S+\.ref) \.\.\.", r.stdout)
        if r.returncode != 0 or not m:
            raise RuntimeError("converge: no reference written:\n" + r.stdout + r.stderr)
        ref = open(m.group(1), "rb").read()
        n = w * h
        if ref[:8] != b"MCPTREF1" or struct.unpack_from("<ii", ref, 8) != (w, h):
            raise RuntimeError("the reference cache is not MCPTREF1 %dx%d" % (w, h))
        values = []  # each pixel's reference mean, all three channels
        for i in range(n):
            k = i % 360
            if k < 300:  # x = 1e-5 .. 3, log-spaced: t = -0.25 .. 1.12
                x = 10 ** (-5 + math.log10(3e5) * k / 299)
                values.append(0.01 * x / (1 - x) if x < 1 else -0.01 * x / (1 + x))
            elif k < 350:  # sum ref from -1.5 to 1.44: x negative, 0 and small
                values.append(-0.5 + (k - 300) / 50)
            else:
                values.append([0.0, -0.0, math.nan, math.inf, -math.inf, -0.01, -0.005,
                               1e300, 1e-300, 5e-7][k - 350])
        mean = [v for v in values for _ in range(3)]
        with open(m.group(1), "wb") as o:
            o.write(ref[:24] + struct.pack("<%dd" % (3 * n), *mean) + bytes(24 * n))
        r = subprocess.run(conv + ["--report", tmp + "/converge"], capture_output=True,
                           text=True, env=env, timeout=300)
        if r.returncode != 0 or "reference: cached " + m.group(1) not in r.stdout:
            raise RuntimeError("converge did not read the rewritten reference:\n" + r.stdout +
                               r.stderr)
        images = report_images(open(tmp + "/converge/index.html").read())
        (final_caption, _, _, final), (error_caption, ew, eh, error) = images[-2:]
        if not final_caption.startswith("Final image") or (ew, eh) != (w, h) or \
                not error_caption.startswith("Per-pixel relative error"):
            raise RuntimeError("converge's report: not its final image and error map")
        lo = f32(1e-4)
        for i in range(n):
            if any(final[3 * i:3 * i + 3]):
                continue  # the light, seen directly: the image is not 0 there
            diff = value = 0.0
            for c in range(3):  # relative_error_map(), in its order
                diff += abs(0.0 - mean[3 * i + c])
                value += mean[3 * i + c]
            if value + 0.03 == 0:
                continue
            x = f32(diff / (value + 0.03))
            t = x if not math.isfinite(x) else 0.0 if x <= 0 else \
                f32((math.log10(x) - math.log10(lo)) / (math.log10(1.0) - math.log10(lo)))
            cases.append(("s", t, tuple(error[3 * i:3 * i + 3])))
        # z_color: B's lamps at half and at twice their power, z of independent seeds.
        for scale in ["0.5", "2"]:
            out = "%s/z%s" % (tmp, scale)
            r = subprocess.run([MCPT, "compare", "cornell", "--a", "opencl", "--b", "opencl",
                                "--batches", "8", "--spp", "4", "--same-seed-spp", "1",
                                "--b-light-scale", scale, "--report", out, "-o", out + ".exr"]
                               + small, capture_output=True, text=True, env=env, timeout=300)
            if r.returncode not in (0, 2):
                raise RuntimeError("compare failed:\n" + r.stdout + r.stderr)
            zw, zh, channels = read_exr(open(out + ".exr", "rb").read())
            caption, mw, mh, zmap = report_images(open(out + "/index.html").read())[0]
            if (zw, zh, mw, mh) != (w, h, w, h) or not caption.startswith("Per-pixel Welch z"):
                raise RuntimeError("compare's report: not its z map")
            cases += [("z", z, tuple(zmap[3 * i:3 * i + 3])) for i, z in enumerate(channels["G"])]
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    # The unit test's cases: EXPECT_EQ(z_color(X), (Rgb8{r, g, b})) and kWhite, kMagenta.
    named = {"kWhite": (255, 255, 255), "kMagenta": (255, 0, 255)}
    special = {"std::numeric_limits<float>::quiet_NaN()": math.nan,
               "std::numeric_limits<float>::infinity()": math.inf}
    text = open(os.path.join(HERE, "..", "false_color_test.cpp")).read()
    pinned = re.findall(r"EXPECT_EQ\((z|sequential)_color\((-?)([^()]+(?:\(\))?)\),\s*\(?"
                        r"(kWhite|kMagenta|Rgb8\{\d+, \d+, \d+\})\)?\);", text)
    for family, sign, arg, rgb in pinned:
        v = special[arg] if arg in special else f32(float(arg.rstrip("f")))
        cases.append((family[0], -v if sign else v, named.get(rgb) or
                      tuple(int(c) for c in re.findall(r"\d+", rgb[4:]))))
    return cases, len(pinned)


def js_number(v):
    """A double as JavaScript's Number() reads it back exactly."""
    if math.isnan(v):
        return "NaN"
    if math.isinf(v):
        return "-Infinity" if v < 0 else "Infinity"
    return repr(v)


def check_false_colors(drv, cases, pinned):
    """The page's zColor and sequentialColor over the cases: the C++ bytes exactly."""
    got = drv.execute_script("return arguments[0].map(([f, v]) => (f === 'z' ? zColor : "
                             "sequentialColor)(Number(v)))", [[f, js_number(v)] for f, v, _ in cases])
    for family, name in [("z", "zColor"), ("s", "sequentialColor")]:
        mine = [(v, c, tuple(g)) for (f, v, c), g in zip(cases, got) if f == family]
        off = [(v, c, g) for v, c, g in mine if c != g]
        finite = [v for v, _, _ in mine if math.isfinite(v)]
        if family == "z":
            parts = [sum(v <= -5 for v in finite), sum(-5 < v < 0 for v in finite),
                     sum(v == 0 for v in finite), sum(0 < v < 5 for v in finite),
                     sum(v >= 5 for v in finite), len(mine) - len(finite)]
            spread = "%d at z <= -5, %d in (-5, 0), %d at 0, %d in (0, 5), %d at z >= 5, %d " \
                     "not finite" % tuple(parts)
        else:
            parts = [sum(v < 0 for v in finite)] + \
                    [sum(k / 4 <= v < (k + 1) / 4 for v in finite) for k in range(4)] + \
                    [sum(v >= 1 for v in finite), len(mine) - len(finite)]
            spread = "%d at t < 0, %d/%d/%d/%d between the stops, %d at t >= 1, %d not finite" \
                     % tuple(parts)
        covered = min(parts) >= 2
        check(len(mine) >= 500 and covered and not off,
              "the page's %s is the C++ one at all %d inputs (%s)%s" %
              (name, len(mine), spread, "; %d differ, e.g. %s: C++ %s, page %s" %
               ((len(off),) + off[0]) if off else ""))
    check(pinned >= 15, "with the C++ unit test's %d cases among them" % pinned)


size = ["--width", "256", "--height", "256"] if SHOTS else ["--width", "96", "--height", "96"]
started = time.time()
FALSE_COLORS = cpp_false_colors()
print("(the C++ false colours: %.1f s)" % (time.time() - started))

# ---- one side: the image converges, the controls work
proc, port, url = start_view(MCPT, ["cornell"] + size)
drv = browser()
try:
    # Without the token: refused. With it (the printed address): the page, the cookie set,
    # the token gone from the address bar.
    drv.get("http://127.0.0.1:%d/" % port)
    check("mcpt view" not in drv.title and "no valid token" in drv.page_source,
          "the page without the token is refused")
    drv.get(url)
    check("mcpt view" in drv.title, "the page loads from the printed address")
    check("token" not in drv.current_url, "the token leaves the address bar (%s)" % drv.current_url)
    wait_for(drv, "window.mcptView.framesDrawn >= 1", "the first image")
    first = canvas(drv, "image-0")
    spp1 = int(drv.find_element(By.ID, "spp-0").text)
    check(first["w"] == int(size[1]) and first["mean"] > 5, "the image is drawn (%dx%d, mean %.1f)"
          % (first["w"], first["h"], first["mean"]))
    wait_for(drv, "window.mcptView.framesDrawn >= 3", "two more images")
    second = canvas(drv, "image-0")
    spp2 = int(drv.find_element(By.ID, "spp-0").text)
    check(second["hash"] != first["hash"], "the displayed pixels change as it renders")
    check(spp2 > spp1, "the sample count grows (%d -> %d)" % (spp1, spp2))
    err = canvas(drv, "error-0")
    check(err["w"] == first["w"] and err["mean"] > 5, "the relative error map is drawn")
    # Paused, the image stays; the exposure brightens it, the linear display changes it.
    drv.find_element(By.ID, "pause").click()
    wait_for(drv, "window.mcptView.state && window.mcptView.state.paused", "pause")
    # The step under way when it paused still ends in a frame: wait until none comes for 1.5 s.
    last, still = None, 0
    deadline = time.time() + 120
    while still < 3 and time.time() < deadline:
        serial = drv.execute_script("return window.mcptView.serial[0]")
        still = still + 1 if serial == last else 0
        last = serial
        time.sleep(0.5)
    held = canvas(drv, "image-0")
    drv.execute_script("const e = document.getElementById('exposure'); e.value = 2;"
                       "e.dispatchEvent(new Event('input'));")
    brighter = canvas(drv, "image-0")
    check(brighter["mean"] > held["mean"] * 1.2,
          "exposure +2 EV brightens the displayed pixels (%.1f -> %.1f)" % (held["mean"], brighter["mean"]))
    drv.execute_script("const e = document.getElementById('exposure'); e.value = 0;"
                       "e.dispatchEvent(new Event('input'));")
    restored = canvas(drv, "image-0")
    check(restored["hash"] == held["hash"] or restored["mean"] == held["mean"],
          "exposure 0 shows the same pixels again")
    drv.execute_script("const s = document.getElementById('display'); s.value = 'linear';"
                       "s.dispatchEvent(new Event('change'));")
    linear = canvas(drv, "image-0")
    check(linear["mean"] < held["mean"], "the linear display is darker than sRGB (%.1f < %.1f)"
          % (linear["mean"], held["mean"]))
    drv.execute_script("const s = document.getElementById('display'); s.value = 'srgb';"
                       "s.dispatchEvent(new Event('change'));")
    # The page's false colours: the C++ ones.
    check_false_colors(drv, *FALSE_COLORS)
    # Hovering a pixel shows its radiance, standard error and sample count.
    img = drv.find_element(By.ID, "image-0")
    ActionChains(drv).move_to_element_with_offset(img, 5, 5).perform()
    wait_for(drv, "document.getElementById('readout').textContent.includes('radiance')", "hover")
    readout = drv.find_element(By.ID, "readout").text
    check("radiance" in readout and "standard error" in readout and "samples" in readout,
          "hover shows the pixel: " + readout.replace("\n", " | "))
    drv.find_element(By.ID, "resume").click()
    wait_for(drv, "window.mcptView.state && !window.mcptView.state.paused", "resume")
    if SHOTS:
        time.sleep(8)
    shoot(drv, "view.png")
finally:
    drv.quit()
    stop_view(proc)


# ---- one side on two devices: the page shows each one's share
proc, port, url = start_view(MCPT, ["cornell", "--device", "0", "--device", "0"] + size)
drv = browser()
try:
    drv.get(url)
    wait_for(drv, "(document.getElementById('devices-0') || {textContent: ''}).textContent"
                  ".split('%').length === 3", "the devices' shares")
    text = drv.find_element(By.ID, "devices-0").text
    check(text.count("%") == 2, "two devices: the page shows each one's share (%s)" % text)
finally:
    drv.quit()
    stop_view(proc)


# ---- A and B: OpenCL against Vulkan, then a B whose light is 3% brighter
def ab(scale, spp):
    extra = ["--b-light-scale", str(scale)] if scale != 1 else []
    proc, port, url = start_view(MCPT, ["cornell", "--a", "opencl", "--b", "vulkan", "--spp", str(spp)]
                                 + size + extra)
    drv = browser()
    try:
        drv.get(url)
        wait_for(drv, "window.mcptView.mapsSpp >= %d" % spp, "A and B at %d spp" % spp)
        wait_for(drv, "window.mcptView.serial[0] > 0 && window.mcptView.serial[1] > 0 &&"
                      "window.mcptView.frames[0].spp >= %d && window.mcptView.frames[1].spp >= %d"
                      % (spp, spp), "both final images")
        a, b, z = canvas(drv, "image-0"), canvas(drv, "image-1"), canvas(drv, "z-map")
        d = canvas(drv, "divergence-map")
        light = drv.execute_script(AT_LIGHT)
        noisy = drv.execute_script(NOISY, scale)
        diverged = drv.execute_script("return window.mcptView.maps.diverged / window.mcptView.maps.pixels")
        return a, b, z, d, light, noisy, diverged, drv, proc
    except BaseException:
        drv.quit()
        stop_view(proc)
        raise


a, b, z, d, light, noisy, diverged, drv, proc = ab(1, 64)
try:
    check(a["mean"] > 5 and b["mean"] > 5 and z["w"] == a["w"] and d["w"] == a["w"],
          "the A/B page shows both images, the z map and the divergence map")
    check(z["hot"] < 0.01, "OpenCL vs Vulkan: the z map stays white (%.2f%% of pixels at |z| >= 4)"
          % (100 * z["hot"]))
    check(diverged < 0.01, "OpenCL vs Vulkan: %.3f%% of pixels diverged (same seed)" % (100 * diverged))
    shoot(drv, "view-ab.png")
finally:
    drv.quit()
    stop_view(proc)
# The control: B's lamps 3% brighter. Where the light is seen directly there is no noise and
# z is in the thousands whatever the variance; on the noisy pixels z is the bias over the
# noise, and its median at 64 spp (at 96x96, the same seed on every device) is 0.30, what a
# wrongly scaled variance moves: the threshold, 0.21 = 0.30 / sqrt(2), fails a variance 4
# times too large (z 0.15) and passes the right one with a margin of sqrt(2). And each
# pixel's z is the bias its own error byte predicts: median ratio 1.00 (0.99 to 1.01 between
# the 10th and 90th percentiles), 0.5 for a variance 4 times too large, 0.71 for twice, 1.41
# for half.
Z_NOISY_MIN = 0.21
a, b, z, d, light, noisy, diverged, drv, proc = ab(1.03, 64)
try:
    check(light["pixels"] > 0 and light["hot"] > 0.9,
          "B's light 3%% brighter: the z map lights up at the light (%.0f%% of its %d pixels)"
          % (100 * light["hot"], light["pixels"]))
    check(noisy["pixels"] > noisy["of"] // 2 and noisy["z"] >= Z_NOISY_MIN,
          "and shows the bias on the noisy pixels: median z %.3f >= %.2f over %d of %d pixels"
          % (noisy["z"], Z_NOISY_MIN, noisy["pixels"], noisy["of"]))
    check(0.9 <= noisy["ratio"] <= 1.1,
          "each as its noise predicts: median z / (0.03 / (sqrt(1 + 1.03^2) relative error)) "
          "%.3f, within 10%% of 1" % noisy["ratio"])
    check(diverged > 0.5, "and the same-seed divergence map flags %.0f%% of the pixels" % (100 * diverged))
    shoot(drv, "view-ab-brighter-light.png")
finally:
    drv.quit()
    stop_view(proc)

print("%d failed" % len(failures) if failures else "all passed")
sys.exit(1 if failures else 0)
