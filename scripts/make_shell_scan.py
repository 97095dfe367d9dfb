#!/usr/bin/env python3
"""Writes a synthetic scan of a thick spherical shell as a NRRD image.

The samples are a distance-like field of the shell a < r < b,
    d(r) = min(r - a, b - r)   (positive in the wall),
mapped to grey values  v = 127.5 + 127.5 d / w  (clamped to 0..255, uint8,
gzip), so the wall is where v > 127.5 and the iso-surface is the two
spheres r = a and r = b, to within the trilinear interpolation of the
samples. The image covers the cube [-L, L]^3 with n samples per axis,
placed by `space directions` and `space origin`.

    python3 scripts/make_shell_scan.py                # cases/scans/shell.nrrd
    python3 scripts/make_shell_scan.py out.nrrd --n 96 --float

`--float` writes float32 values of d itself (threshold 0) instead.
Standard library only.
"""

import argparse
import gzip
import math
import struct


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out", nargs="?", default="cases/scans/shell.nrrd")
    ap.add_argument("--n", type=int, default=64, help="samples per axis")
    ap.add_argument("--inner", type=float, default=0.5, help="inner radius a")
    ap.add_argument("--outer", type=float, default=1.0, help="outer radius b")
    ap.add_argument("--half-width", type=float, default=1.1, help="L: the image is [-L, L]^3")
    ap.add_argument("--ramp", type=float, default=0.3, help="w: the distance mapped to 127.5 grey levels")
    ap.add_argument("--float", action="store_true", help="float32 distances instead of uint8 grey")
    args = ap.parse_args()

    n, a, b, L, w = args.n, args.inner, args.outer, args.half_width, args.ramp
    h = 2.0 * L / (n - 1)
    out = bytearray()
    for k in range(n):
        z = -L + k * h
        for j in range(n):
            y = -L + j * h
            for i in range(n):
                x = -L + i * h
                r = math.sqrt(x * x + y * y + z * z)
                d = min(r - a, b - r)
                if args.float:
                    out += struct.pack("<f", d)
                else:
                    v = round(127.5 + 127.5 * d / w)
                    out.append(min(255, max(0, v)))
    header = (
        "NRRD0004\n"
        "# A thick spherical shell, inner radius {a}, outer radius {b}: "
        "scripts/make_shell_scan.py\n"
        "type: {t}\n"
        "dimension: 3\n"
        "space: right-anterior-superior\n"
        "sizes: {n} {n} {n}\n"
        "space directions: ({h!r},0,0) (0,{h!r},0) (0,0,{h!r})\n"
        "kinds: domain domain domain\n"
        "endian: little\n"
        "encoding: gzip\n"
        "space origin: ({o!r},{o!r},{o!r})\n"
        "\n"
    ).format(a=a, b=b, t="float" if args.float else "uint8", n=n, h=h, o=-L)
    with open(args.out, "wb") as f:
        f.write(header.encode("ascii"))
        f.write(gzip.compress(bytes(out), compresslevel=9, mtime=0))


if __name__ == "__main__":
    main()
