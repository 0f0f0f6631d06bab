#!/usr/bin/env python3
"""Cuts frames [FIRST, FIRST + COUNT) out of a BVH file, keeping its hierarchy and frame time.
Root positions keep 6 decimals; rotations are rounded to ROT_DECIMALS (degrees) and exact zeros
are written as 0, which keeps a bundled excerpt small. Made cmu_131_01_walk_2s.bvh with:

  python3 examples/motion/excerpt_bvh.py ../shared/data/mocap/scaled_131_01_walk.bvh \\
      examples/motion/cmu_131_01_walk_2s.bvh 510 240 5

usage: excerpt_bvh.py SOURCE.bvh OUT.bvh FIRST COUNT ROT_DECIMALS
"""
import sys


def number(text, decimals):
    s = f"{float(text):.{decimals}f}"
    return "0" if float(s) == 0 else s


def main():
    src, dst, first, count, rot_decimals = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5])
    lines = open(src).read().split("\n")
    m = lines.index("MOTION")
    frames = [line for line in lines[m + 3:] if line.strip()]
    if first < 0 or count <= 0 or first + count > len(frames):
        sys.exit(f"{src} has {len(frames)} frames: cannot take [{first}, {first + count})")
    out = lines[:m + 1] + [f"Frames: {count}", lines[m + 2]]
    for line in frames[first:first + count]:
        v = line.split()
        out.append(" ".join([number(x, 6) for x in v[:3]] + [number(x, rot_decimals) for x in v[3:]]))
    with open(dst, "w") as f:
        f.write("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
