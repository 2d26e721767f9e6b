#!/usr/bin/env python3
"""tools/make_textures.py — writes the textures of scene/textured.rib and scene/lama.rib
(standard library only).

  scene/textures/cobbles_height.pgm  128 x 128, 8 bit: a 4 x 4 grid of rounded cobbles
                                     (value 1 at a cobble's crown, 0 in the mortar), each
                                     cobble a little higher or lower and rougher than the next
  scene/textures/cobbles_colour.ppm  128 x 128, 8 bit: the matching colours, warm greys per
                                     cobble and dark mortar
  scene/textures/leaf_mask.pgm       64 x 64, 8 bit: a leaf's silhouette along t, 1 inside and
                                     0 outside, for scene/lama.rib's cut-out leaves (presence)

Both tile seamlessly (the renderer repeats textures with period 1 in s and t). Values are
written as stored: 8-bit texels read back as v / 255 (no colour-space conversion).
Usage: tools/make_textures.py [OUT_DIR]   (default scene/textures)
"""
import math
import os
import random
import sys

N = 128          # texels a side
CELLS = 4        # cobbles a side
GAP = 0.12       # mortar half-width, in cells


def cobble(x, y, rng_cells):
    """Height in [0, 1] and cell index at texel centre (x, y)."""
    u, v = (x + 0.5) / N * CELLS, (y + 0.5) / N * CELLS
    # Every other row is shifted by half a cell, like laid stones.
    row = int(v)
    u += 0.5 * (row % 2)
    cell = (int(u) % CELLS, row % CELLS)
    fu, fv = u - math.floor(u), v - math.floor(v)
    # Distance to the cell's edge, 0 at the edge, 0.5 at the centre.
    edge = min(fu, 1 - fu, fv, 1 - fv)
    if edge < GAP:
        return 0.0, cell
    t = min(1.0, (edge - GAP) / (0.5 - GAP))
    crown = math.sin(0.5 * math.pi * t) ** 0.6   # rounded shoulder, flat-ish top
    h, rough = rng_cells[cell]
    bump = rough * math.sin(17.0 * fu + 3 * h) * math.sin(13.0 * fv + 5 * h)
    return max(0.0, min(1.0, crown * h + 0.08 * bump * t)), cell


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "scene", "textures")
    os.makedirs(out, exist_ok=True)
    rng = random.Random(2026)
    cells = {(i, j): (rng.uniform(0.75, 1.0), rng.uniform(0.3, 1.0)) for i in range(CELLS) for j in range(CELLS)}
    tint = {c: (rng.uniform(0.45, 0.65), rng.uniform(-0.06, 0.06)) for c in cells}
    height = bytearray()
    colour = bytearray()
    for y in range(N):
        for x in range(N):
            h, cell = cobble(x, y, cells)
            height.append(int(round(255 * h)))
            if h <= 0.0:
                rgb = (0.16, 0.14, 0.12)  # mortar
            else:
                g, warm = tint[cell]
                g *= 0.85 + 0.15 * h
                rgb = (g + warm, g, g - warm)
            colour.extend(int(round(255 * max(0.0, min(1.0, c)))) for c in rgb)
    with open(os.path.join(out, "cobbles_height.pgm"), "wb") as f:
        f.write(b"P5\n%d %d\n255\n" % (N, N) + bytes(height))
    with open(os.path.join(out, "cobbles_colour.ppm"), "wb") as f:
        f.write(b"P6\n%d %d\n255\n" % (N, N) + bytes(colour))
    with open(os.path.join(out, "leaf_mask.pgm"), "wb") as f:
        f.write(b"P5\n%d %d\n255\n" % (LEAF, LEAF) + leaf_mask())


LEAF = 64  # texels a side of the leaf mask


def leaf_mask():
    """A leaf along t: inside where |s - 1/2| is below its half-width 0.45 sin(pi t)^0.7,
    pointed at both ends; 255 inside, 0 outside, at the texel centres."""
    texels = bytearray()
    for y in range(LEAF):
        for x in range(LEAF):
            s, t = (x + 0.5) / LEAF, (y + 0.5) / LEAF
            half = 0.45 * math.sin(math.pi * t) ** 0.7
            texels.append(255 if abs(s - 0.5) < half else 0)
    return bytes(texels)


if __name__ == "__main__":
    main()
