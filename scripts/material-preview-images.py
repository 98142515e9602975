#!/usr/bin/env python3
"""The images of scenes/material-preview.toml, made here (no downloaded image), with the Python
standard library only:

* studio.hdr: a procedural photographic studio as an equirectangular environment map (Radiance
  RGBE, 256 x 128, rows from +y down as brdfwave and Mitsuba 3 read it): a dark floor and a
  darker backdrop joined by a soft horizon gradient, a large warm key softbox to the front left,
  a cool fill to the right, a strip light behind and a small round top light. Radiance is in
  arbitrary units; the brightest softbox is about 40x the backdrop.
* ground.png: 8-bit sRGB tiles (a two-tone parquet with a thin grout line), the ground's
  diffuse colour.
* ground-roughness.png: 8-bit grey, the ground's roughness (read as stored: 0.08 on the
  tiles, rising smoothly to 0.35 in the grout), so that a number parameter is a texture too.

The images are committed; run this to make them again:
    python3 scripts/material-preview-images.py scenes/material-preview
The measured material's table is too large to commit: scripts/material-preview.sh writes it.
"""

import math
import os
import struct
import sys
import zlib

W, H = 256, 128


def direction(u, v):
    """The direction of (u, v) in the map's frame: brdfwave's src/envmap.rs (Mitsuba's)."""
    phi, theta = 2 * math.pi * u, math.pi * v
    return (math.sin(phi) * math.sin(theta), math.cos(theta), -math.cos(phi) * math.sin(theta))


def softbox(d, centre, size, radiance):
    """A rectangle of light facing the origin: `centre` a unit direction, `size` its angular
    half-widths (radians) across and up; a soft edge of 10 % of the size."""
    cx, cy, cz = centre
    # An orthonormal frame about the centre: right = up x centre, up' = centre x right.
    rx, ry, rz = cz, 0.0, -cx
    n = math.hypot(rx, rz) or 1.0
    rx, rz = rx / n, rz / n
    ux, uy, uz = cy * rz - cz * ry, cz * rx - cx * rz, cx * ry - cy * rx
    dot = d[0] * cx + d[1] * cy + d[2] * cz
    if dot <= 0:
        return (0.0, 0.0, 0.0)
    a = (d[0] * rx + d[1] * ry + d[2] * rz) / dot
    b = (d[0] * ux + d[1] * uy + d[2] * uz) / dot
    ta, tb = math.tan(size[0]), math.tan(size[1])

    def edge(x, t):
        return max(0.0, min(1.0, (t - abs(x)) / (0.1 * t)))

    k = edge(a, ta) * edge(b, tb)
    return tuple(k * c for c in radiance)


def unit(x, y, z):
    n = math.sqrt(x * x + y * y + z * z)
    return (x / n, y / n, z / n)


LIGHTS = [
    # Key: large, warm, front left and above (the camera looks along +z).
    (unit(-0.8, 0.55, -0.6), (0.38, 0.28), (40.0, 34.0, 27.0)),
    # Fill: cooler, dimmer, right.
    (unit(0.9, 0.25, -0.2), (0.3, 0.22), (7.0, 8.5, 11.0)),
    # Strip light behind, high.
    (unit(0.0, 0.35, 1.0), (0.6, 0.05), (22.0, 22.0, 22.0)),
    # A small top light.
    (unit(0.1, 1.0, 0.05), (0.12, 0.12), (30.0, 30.0, 28.0)),
]


def studio(d):
    y = d[1]
    # Backdrop above the horizon, floor below, a soft bright band at the horizon.
    if y >= 0:
        base = (0.09 + 0.05 * y, 0.095 + 0.05 * y, 0.11 + 0.06 * y)
    else:
        base = (0.05, 0.045, 0.04)
    band = 0.12 * math.exp(-(y / 0.08) ** 2)
    c = [base[i] + band for i in range(3)]
    for centre, size, radiance in LIGHTS:
        s = softbox(d, centre, size, radiance)
        c = [c[i] + s[i] for i in range(3)]
    return c


def rgbe(c):
    m = max(c)
    if m < 1e-32:
        return bytes((0, 0, 0, 0))
    e = math.floor(math.log2(m)) + 1
    s = 256.0 / 2.0**e
    return bytes([min(255, int(x * s)) for x in c] + [e + 128])


def write_hdr(path):
    rows = [b"".join(rgbe(studio(direction((x + 0.5) / W, y / (H - 1)))) for x in range(W)) for y in range(H)]
    with open(path, "wb") as f:
        f.write(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n")
        f.write(b"-Y %d +X %d\n" % (H, W))
        for r in rows:
            f.write(r)


def write_png(path, w, h, pixels, channels):
    """`pixels`: rows of bytes, `channels` 1 (grey) or 3 (RGB), 8 bits."""
    raw = b"".join(b"\0" + bytes(r) for r in pixels)

    def chunk(kind, data):
        c = struct.pack(">I", len(data)) + kind + data
        return c + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    colour = 0 if channels == 1 else 2
    png = b"\x89PNG\r\n\x1a\n"
    png += chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, colour, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 9))
    png += chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(png)


def parquet(x, y, n=256, tiles=4):
    """(tile shade in [0, 1] or None in the grout, a deterministic grain)."""
    t = n // tiles
    tx, ty = x // t, y // t
    lx, ly = x % t, y % t
    if lx < 2 or ly < 2:
        return None
    # Alternate the grain's direction tile by tile, with a few planks each.
    along, across = (lx, ly) if (tx + ty) % 2 == 0 else (ly, lx)
    plank = across // (t // 4)
    grain = 0.5 + 0.5 * math.sin(0.35 * along + 2.1 * plank + 0.6 * math.sin(0.11 * across * (plank + 1)))
    shade = 0.55 + 0.3 * ((plank * 7 + tx * 3 + ty * 5) % 5) / 4.0
    return shade * (0.85 + 0.15 * grain)


def roughness(x, y, n=256, tiles=4):
    """0.08 on the tiles, rising smoothly to 0.35 in the grout over 6 texels: a gentle slope,
    so that a surface point that moves by a rounding error barely changes its roughness."""
    t = n // tiles
    lx, ly = x % t, y % t
    # Distance to the nearest grout line (at 0 and 1 of each tile), in texels.
    d = min(lx, ly, t - lx, t - ly)
    k = max(0.0, min(1.0, d / 6.0))
    k = k * k * (3 - 2 * k)
    return 0.35 + (0.08 - 0.35) * k


def write_ground(dirname):
    n = 256
    colour, rough = [], []
    for y in range(n):
        crow, rrow = [], []
        for x in range(n):
            s = parquet(x, y)
            if s is None:
                crow += [52, 48, 44]
            else:
                crow += [int(255 * s), int(200 * s), int(140 * s)]
            rrow.append(int(255 * roughness(x, y) + 0.5))
        colour.append(crow)
        rough.append(rrow)
    write_png(os.path.join(dirname, "ground.png"), n, n, colour, 3)
    write_png(os.path.join(dirname, "ground-roughness.png"), n, n, rough, 1)


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "scenes/material-preview"
    os.makedirs(out, exist_ok=True)
    write_hdr(os.path.join(out, "studio.hdr"))
    write_ground(out)
    print(f"wrote {out}/studio.hdr, ground.png and ground-roughness.png")


if __name__ == "__main__":
    main()
