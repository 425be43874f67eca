#!/usr/bin/env python3
"""mcpt view in a real browser: Debian's chromium, headless, driven by selenium.

The page loads, the image updates (its pixels change and the sample count grows), the exposure
and display controls change the displayed pixels, hovering shows a pixel's values; the A/B page
shows both images and a z map that stays white for OpenCL against Vulkan and lights up where
the light is for a B whose light is 5% brighter (the negative control).
Exits 77 (skipped) where chromium, chromedriver or selenium is not installed.
Usage: view_browser_test.py MCPT_BINARY; MCPT_VIEW_SCREENSHOTS=DIR also writes the pages'
screenshots there (docs/view.png, docs/view-ab.png) at a larger size."""
import os
import shutil
import sys
import time

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


def canvas(drv, name):
    return drv.execute_script(CANVAS, name)


def shoot(drv, name):
    if SHOTS:
        drv.save_screenshot(os.path.join(SHOTS, name))
        print("wrote " + os.path.join(SHOTS, name))


size = ["--width", "256", "--height", "256"] if SHOTS else ["--width", "96", "--height", "96"]

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


# ---- A and B: OpenCL against Vulkan, then a B whose light is 5% brighter
def ab(extra, spp):
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
        diverged = drv.execute_script("return window.mcptView.maps.diverged / window.mcptView.maps.pixels")
        return a, b, z, d, light, diverged, drv, proc
    except BaseException:
        drv.quit()
        stop_view(proc)
        raise


a, b, z, d, light, diverged, drv, proc = ab([], 64)
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
a, b, z, d, light, diverged, drv, proc = ab(["--b-light-scale", "1.05"], 64)
try:
    check(light["pixels"] > 0 and light["hot"] > 0.9,
          "B's light 5%% brighter: the z map lights up at the light (%.0f%% of its %d pixels)"
          % (100 * light["hot"], light["pixels"]))
    check(diverged > 0.5, "and the same-seed divergence map flags %.0f%% of the pixels" % (100 * diverged))
    shoot(drv, "view-ab-brighter-light.png")
finally:
    drv.quit()
    stop_view(proc)

print("%d failed" % len(failures) if failures else "all passed")
sys.exit(1 if failures else 0)
