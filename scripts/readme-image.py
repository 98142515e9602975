#!/usr/bin/env python3
"""The README's picture of the shipped scenes: docs/shipped-scenes.jpg.

Renders each scene of scenes/ that is a picture (not the furnace tests) with the CPU reference,
at the size below and the scene's own settings otherwise, and sets them in two rows with their
names under them. Needs Pillow (`pip install pillow`); about a minute on 2 cores.

    python3 scripts/readme-image.py [--spp N]     # default 64
"""

import argparse
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
ROWS = [
    [("cornell-box", 200, 200), ("cornell-box-glossy", 200, 200), ("obj-example", 266, 200),
     ("anisotropic", 480, 200)],
    [("lineup", 640, 200), ("material-preview", 480, 200)],
]
LABEL = 22
GAP = 6


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--spp", type=int, default=64)
    args = ap.parse_args()
    try:
        from PIL import Image, ImageDraw
    except ImportError:
        sys.exit("readme-image.py needs Pillow: pip install pillow")
    subprocess.run(["cargo", "build", "--release", "--quiet"], cwd=ROOT, check=True)
    binary = ROOT / "target" / "release" / "brdfwave"
    out = ROOT / "out" / "readme-image"
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for row in ROWS:
        tiles = []
        for name, w, h in row:
            png = out / f"{name}.png"
            subprocess.run([str(binary), "render", str(ROOT / "scenes" / f"{name}.toml"), "--backend",
                            "cpu", "--res", f"{w}x{h}", "--spp", str(args.spp), "--quiet", "--out",
                            str(png)], check=True)
            tiles.append((name, Image.open(png).convert("RGB")))
        rows.append(tiles)
    width = max(sum(t.width for _, t in r) + GAP * (len(r) - 1) for r in rows)
    height = sum(max(t.height for _, t in r) + LABEL for r in rows) + GAP * (len(rows) - 1)
    sheet = Image.new("RGB", (width, height), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    y = 0
    for r in rows:
        row_width = sum(t.width for _, t in r) + GAP * (len(r) - 1)
        x = (width - row_width) // 2
        for name, tile in r:
            sheet.paste(tile, (x, y))
            draw.text((x + 4, y + tile.height + 5), f"scenes/{name}.toml", fill=(40, 40, 40))
            x += tile.width + GAP
        y += max(t.height for _, t in r) + LABEL + GAP
    target = ROOT / "docs" / "shipped-scenes.jpg"
    tmp = target.with_suffix(".tmp.jpg")
    sheet.save(tmp, quality=88)
    tmp.replace(target)
    print(f"{target.relative_to(ROOT)}: {width}x{height}, {target.stat().st_size // 1024} KB")


if __name__ == "__main__":
    main()
