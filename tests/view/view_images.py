"""Exact readers for what the viewer's tests compare, in plain Python (no numpy, no OpenEXR):
the viewer's binary frames (RGBE and error bytes), scan-line EXR files of 32-bit float channels
(uncompressed or ZIP, what `mcpt` writes through tinyexr), 8-bit PNGs and the PNGs of an HTML
report (`mcpt compare --report`, `mcpt converge --report`)."""
import base64
import json
import re
import struct
import zlib


def binary_body(body):
    """The viewer's binary answer (/api/frame, /api/maps): its JSON header and its data."""
    n = struct.unpack("<I", body[:4])[0]
    return json.loads(body[4:4 + n]), body[4 + n:]


def rgbe_pixel(px, i):
    """Pixel i of a frame's RGBE bytes, as the page decodes it: (mantissa + 0.5) 2^(E - 136)
    per channel, E = 0 black, E = 255 not finite (NaN)."""
    e = px[4 * i + 3]
    if e == 255:
        return [float("nan")] * 3
    if e == 0:
        return [0.0] * 3
    return [(px[4 * i + c] + 0.5) * 2.0 ** (e - 136) for c in range(3)]


def error_byte_value(b):
    """A frame's relative-error byte as the relative error it stands for (None: unknown):
    t = (b - 1) / 254, e = 10^(3 t - 3)."""
    return None if b == 0 else 10 ** (3 * (b - 1) / 254 - 3)


def _exr_unzip(data, raw_size):
    """An EXR ZIP block: zlib, then the predictor (byte deltas + 128) and the two halves
    interleaved. A block that did not shrink is stored as it is."""
    if len(data) == raw_size:
        return data
    t = bytearray(zlib.decompress(data))
    acc = t[0] if t else 0
    for i in range(1, len(t)):
        acc = (acc + t[i] - 128) & 255
        t[i] = acc
    half = (len(t) + 1) // 2
    out = bytearray(len(t))
    out[0::2] = t[:half]
    out[1::2] = t[half:]
    return bytes(out)


def read_exr(data):
    """A single-part scan-line EXR of FLOAT channels, uncompressed or ZIP/ZIPS: width, height
    and {channel name: [value per pixel, top row first]}. Anything else raises ValueError."""
    if data[:4] != b"\x76\x2f\x31\x01":
        raise ValueError("not an EXR file")
    if data[4] != 2 or data[5] & 0x1a:
        raise ValueError("not a single-part scan-line EXR (version %d, flags %#x)"
                         % (data[4], data[5]))
    at, attrs = 8, {}
    while data[at] != 0:
        name_end = data.index(b"\0", at)
        type_end = data.index(b"\0", name_end + 1)
        size = struct.unpack_from("<i", data, type_end + 1)[0]
        attrs[data[at:name_end].decode()] = data[type_end + 5:type_end + 5 + size]
        at = type_end + 5 + size
    at += 1
    channels, c = [], attrs["channels"]
    i = 0
    while c[i] != 0:
        end = c.index(b"\0", i)
        pixel_type, _, _, xs, ys = struct.unpack_from("<iB3sii", c, end + 1)
        if pixel_type != 2 or xs != 1 or ys != 1:
            raise ValueError("channel %s is not a full-resolution FLOAT" % c[i:end])
        channels.append(c[i:end].decode())
        i = end + 1 + 16
    compression = attrs["compression"][0]
    lines = {0: 1, 2: 1, 3: 16}.get(compression)
    if lines is None:
        raise ValueError("EXR compression %d is not read here" % compression)
    x0, y0, x1, y1 = struct.unpack("<iiii", attrs["dataWindow"])
    w, h = x1 - x0 + 1, y1 - y0 + 1
    chunks = (h + lines - 1) // lines
    offsets = struct.unpack_from("<%dQ" % chunks, data, at)
    values = {name: [0.0] * (w * h) for name in channels}
    for off in offsets:
        y, size = struct.unpack_from("<ii", data, off)
        rows = min(lines, y1 + 1 - y)
        raw = 4 * w * len(channels) * rows
        block = data[off + 8:off + 8 + size]
        block = block if compression == 0 else _exr_unzip(block, raw)
        if len(block) != raw:
            raise ValueError("EXR block at line %d: %d bytes, not %d" % (y, len(block), raw))
        floats = struct.unpack("<%df" % (raw // 4), block)
        k = 0
        for r in range(rows):
            row = (y - y0 + r) * w
            for name in channels:
                values[name][row:row + w] = floats[k:k + w]
                k += w
    return w, h, values


def _paeth(a, b, c):
    p = a + b - c
    pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
    return a if pa <= pb and pa <= pc else (b if pb <= pc else c)


def read_png(data):
    """A non-interlaced 8-bit RGB or RGBA PNG: width, height and its RGB bytes (3 a pixel, top
    row first)."""
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError("not a PNG")
    at, idat, head = 8, b"", None
    while at < len(data):
        size, kind = struct.unpack_from(">I4s", data, at)
        chunk = data[at + 8:at + 8 + size]
        if kind == b"IHDR":
            head = struct.unpack(">IIBBBBB", chunk)
        elif kind == b"IDAT":
            idat += chunk
        at += 12 + size
    w, h, depth, color, _, _, interlace = head
    if depth != 8 or color not in (2, 6) or interlace:
        raise ValueError("PNG not 8-bit RGB(A), non-interlaced: %s" % (head,))
    bpp = 3 if color == 2 else 4
    raw, stride = zlib.decompress(idat), w * bpp
    out, prev = bytearray(), bytearray(stride)
    for y in range(h):
        f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b, c = prev[i], prev[i - bpp] if i >= bpp else 0
            line[i] = (line[i] + (0, a, b, (a + b) // 2, _paeth(a, b, c))[f]) & 255
        out += line if bpp == 3 else bytes(v for i, v in enumerate(line) if i % 4 != 3)
        prev = line
    return w, h, bytes(out)


def report_images(html):
    """The images of an `mcpt ... --report` page, in order: (caption, width, height, RGB)."""
    found = []
    for m in re.finditer(r'<img src="data:image/png;base64,([^"]+)"[^>]*alt="([^"]*)"', html):
        w, h, rgb = read_png(base64.b64decode(m.group(1)))
        found.append((m.group(2), w, h, rgb))
    return found
