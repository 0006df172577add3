#!/usr/bin/env python3
"""Checks that a PNG screenshot is not blank: decodes it with the standard library only
(zlib + the five PNG row filters) and requires at least MIN_COLOURS distinct colours and at
least MIN_INK of the pixels away from the background (the most common colour).

Usage: png-not-blank.py FILE.png  -> prints what it measured; exit 1 when blank."""

import struct
import sys
import zlib

MIN_COLOURS = 16
MIN_INK = 0.01  # fraction of pixels that differ from the background colour


def decode(path):
    data = open(path, "rb").read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError(f"{path}: not a PNG file")
    pos, idat, hdr = 8, b"", None
    while pos < len(data):
        (n,) = struct.unpack(">I", data[pos : pos + 4])
        kind = data[pos + 4 : pos + 8]
        body = data[pos + 8 : pos + 8 + n]
        pos += 12 + n
        if kind == b"IHDR":
            hdr = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        elif kind == b"IEND":
            break
    w, h, depth, ctype, _, _, interlace = hdr
    channels = {0: 1, 2: 3, 4: 2, 6: 4}.get(ctype)
    if depth != 8 or channels is None or interlace != 0:
        raise ValueError(f"{path}: unsupported PNG (depth {depth}, colour type {ctype}, interlace {interlace})")
    raw = zlib.decompress(idat)
    stride = w * channels
    rows, prev, i = [], bytearray(stride), 0
    for _ in range(h):
        f = raw[i]
        line = bytearray(raw[i + 1 : i + 1 + stride])
        i += 1 + stride
        for x in range(stride):
            a = line[x - channels] if x >= channels else 0
            b = prev[x]
            c = prev[x - channels] if x >= channels else 0
            if f == 1:
                line[x] = (line[x] + a) & 255
            elif f == 2:
                line[x] = (line[x] + b) & 255
            elif f == 3:
                line[x] = (line[x] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[x] = (line[x] + pred) & 255
        rows.append(bytes(line))
        prev = line
    return w, h, channels, rows


def main():
    path = sys.argv[1]
    w, h, ch, rows = decode(path)
    counts = {}
    for r in rows:
        for x in range(0, len(r), ch):
            px = r[x : x + ch]
            counts[px] = counts.get(px, 0) + 1
    total = w * h
    bg, nbg = max(counts.items(), key=lambda kv: kv[1])
    ink = 1 - nbg / total
    ok = len(counts) >= MIN_COLOURS and ink >= MIN_INK
    print(
        f"{path}: {w}x{h}, {len(counts)} distinct colours, {100 * ink:.1f} % of pixels off the "
        f"background {bg.hex()} -> {'not blank' if ok else 'BLANK'} "
        f"(needs >= {MIN_COLOURS} colours and >= {100 * MIN_INK:.0f} %)"
    )
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
