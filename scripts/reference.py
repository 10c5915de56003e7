#!/usr/bin/env python3
"""Reference images: the average of independent PFM renders, and the reference's own error.

  scripts/reference.py average OUT.pfm A.pfm B.pfm ...
      writes the pixel mean of the inputs (independent renders of one scene, equal weight).
  scripts/reference.py halves A.pfm B.pfm
      A and B: two independent unbiased renders of equal effort. Prints the relMSE their
      average carries as a reference: mean (A - B)^2 / (M^2 + 1e-2) / 4, M = (A + B) / 2
      (each half's error is half of E (A - B)^2, the average's half of a half's).
  scripts/reference.py floor REF.pfm A.pfm B.pfm
      A and B: two independent *unbiased* renders, both independent of REF. Prints the relMSE
      (segpath-render's: mean over pixels and channels of (x - r)^2 / (r^2 + 1e-2)) that REF's
      own noise adds to every relMSE measured against it:
        relMSE(A, REF) ~ e_A + f,  relMSE(B, REF) ~ e_B + f,  mean (A - B)^2 / (REF^2 + 1e-2) ~ e_A + e_B,
      so f ~ (relMSE(A, REF) + relMSE(B, REF) - that) / 2.
  scripts/reference.py relmse IMAGE.pfm REF.pfm
      prints IMAGE's relMSE against REF as segpath-render computes it (for another renderer's
      PFM, e.g. SmallVCM's) and both image means.
Only the standard library; PFM as segpath-render writes it (RGB, "PF").
"""

import array
import sys


def read_pfm(path):
    with open(path, "rb") as f:
        if f.readline().strip() != b"PF":
            raise ValueError(f"{path}: not an RGB PFM")
        width, height = map(int, f.readline().split())
        scale = float(f.readline())
        pixels = array.array("f")
        pixels.frombytes(f.read(width * height * 3 * 4))
        if (scale < 0) != (sys.byteorder == "little"):
            pixels.byteswap()
        return width, height, pixels


def write_pfm(path, width, height, pixels):
    with open(path, "wb") as f:
        f.write(b"PF\n%d %d\n%s\n" % (width, height, b"-1.0" if sys.byteorder == "little" else b"1.0"))
        pixels.tofile(f)


def average(out, inputs):
    images = [read_pfm(p) for p in inputs]
    width, height = images[0][0], images[0][1]
    if any((w, h) != (width, height) for w, h, _ in images):
        raise ValueError("the inputs differ in size")
    total = array.array("f", [0.0]) * (width * height * 3)
    for _, _, pixels in images:
        for i, v in enumerate(pixels):
            total[i] += v
    n = float(len(images))
    write_pfm(out, width, height, array.array("f", (v / n for v in total)))


def halves(a, b):
    _, _, x = read_pfm(a)
    _, _, y = read_pfm(b)
    if len(x) != len(y):
        raise ValueError("the images differ in size")
    total = 0.0
    for u, v in zip(x, y):
        m = 0.5 * (u + v)
        total += (u - v) ** 2 / (m * m + 1e-2)
    print(f"the average's own relMSE as a reference: {total / len(x) / 4:.5f}")


def floor(ref, a, b):
    _, _, r = read_pfm(ref)
    _, _, x = read_pfm(a)
    _, _, y = read_pfm(b)
    if not len(r) == len(x) == len(y):
        raise ValueError("the images differ in size")
    xr = yr = xy = 0.0
    for u, v, w in zip(x, y, r):
        d = w * w + 1e-2
        xr += (u - w) ** 2 / d
        yr += (v - w) ** 2 / d
        xy += (u - v) ** 2 / d
    n = len(r)
    xr, yr, xy = xr / n, yr / n, xy / n
    print(f"relMSE(A, REF) {xr:.5f}, relMSE(B, REF) {yr:.5f}, A against B {xy:.5f}: "
          f"REF's own relMSE f = {(xr + yr - xy) / 2:.5f}")


def relmse(image, ref):
    _, _, x = read_pfm(image)
    _, _, r = read_pfm(ref)
    if len(x) != len(r):
        raise ValueError("the images differ in size")
    total = sum((u - v) ** 2 / (v * v + 1e-2) for u, v in zip(x, r))
    print(f"relMSE {total / len(r):.5f}, mean {sum(x) / len(x):.5f}, reference mean {sum(r) / len(r):.5f}")


if __name__ == "__main__":
    if len(sys.argv) >= 4 and sys.argv[1] == "average":
        average(sys.argv[2], sys.argv[3:])
    elif len(sys.argv) == 4 and sys.argv[1] == "halves":
        halves(sys.argv[2], sys.argv[3])
    elif len(sys.argv) == 5 and sys.argv[1] == "floor":
        floor(sys.argv[2], sys.argv[3], sys.argv[4])
    elif len(sys.argv) == 4 and sys.argv[1] == "relmse":
        relmse(sys.argv[2], sys.argv[3])
    else:
        sys.exit(__doc__)
