#!/usr/bin/env python3
"""uv-checker.py OUT.png [SIZE [CELLS]]: a UV test texture as PNG (python3
zlib + struct only): CELLS x CELLS checker squares whose hue runs with u
(left to right) and whose brightness runs with v, light and dark squares
alternating, so a viewer shows where each part of the UV square lands and
whether v is flipped (the bottom row, v near 0, is the darkest).  SIZE
defaults to 256 pixels, CELLS to 8."""
import colorsys
import struct
import sys
import zlib


def png(path, w, h, rows):
    def chunk(kind, data):
        c = struct.pack(">I", len(data)) + kind + data
        return c + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)
    raw = b"".join(b"\x00" + bytes(r) for r in rows)  # filter 0 on every row
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)))
        f.write(chunk(b"IDAT", zlib.compress(raw, 9)))
        f.write(chunk(b"IEND", b""))


def main():
    out = sys.argv[1]
    size = int(sys.argv[2]) if len(sys.argv) > 2 else 256
    cells = int(sys.argv[3]) if len(sys.argv) > 3 else 8
    rows = []
    for y in range(size):
        v = 1.0 - (y + 0.5) / size  # image rows run top down; v runs up
        row = []
        for x in range(size):
            u = (x + 0.5) / size
            cu, cv = int(u * cells), int(v * cells)
            light = (cu + cv) % 2 == 0
            r, g, b = colorsys.hsv_to_rgb(cu / cells, 0.75 if light else 0.9,
                                          (0.55 + 0.45 * cv / (cells - 1)) * (1.0 if light else 0.6))
            row += [int(255 * r + 0.5), int(255 * g + 0.5), int(255 * b + 0.5)]
        rows.append(row)
    png(out, size, size, rows)


if __name__ == "__main__":
    main()
