#!/usr/bin/env python3
"""Writes atrium.glb: a courtyard with two storeys of arcades, in the spirit of the Crytek Sponza
atrium that lightmappers are shown on, as a glTF exporter writes it.

  - About 290,000 triangles: 40 fluted columns with capitals and bases, round arches, walls,
    floors, balustrades, banners, potted plants and lanterns.
  - 24 textures (PNG, generated here): stone, plaster, bricks, floor tiles, wood, terracotta,
    fabric, leaves; each material's colour comes from its texture (baseColorFactor left at 1),
    some read through KHR_texture_transform (tiling).
  - Alpha-tested foliage, banners with cut fringes and balustrades (alphaMode MASK).
  - A sun (KHR_lights_punctual directional light, 100,000 lx) through the open roof, and
    lanterns (emissive meshes, KHR_materials_emissive_strength) along the arcades.

numpy and the standard library only; the same bytes on every run.

Usage: make_atrium.py [OUTPUT]   (default: atrium.glb in the current folder)
"""

import json
import math
import struct
import sys
import zlib

import numpy as np


# ---- textures -------------------------------------------------------------------------------

def png(rgba):
    """An 8-bit RGBA PNG of an (h, w, 4) uint8 array."""
    h, w, _ = rgba.shape

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)

    raw = b"".join(b"\0" + rgba[y].tobytes() for y in range(h))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 6, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def noise(size, seed, scale):
    """Smooth value noise in [0, 1], periodic over the image, `scale` cells across."""
    rng = np.random.default_rng(seed)
    cells = rng.random((scale, scale))
    t = np.arange(size) * scale / size
    i0 = np.floor(t).astype(int) % scale
    i1 = (i0 + 1) % scale
    f = t - np.floor(t)
    f = f * f * (3 - 2 * f)
    rows = cells[i0][:, i0] * (1 - f)[None, :] + cells[i0][:, i1] * f[None, :]
    rows1 = cells[i1][:, i0] * (1 - f)[None, :] + cells[i1][:, i1] * f[None, :]
    return rows * (1 - f)[:, None] + rows1 * f[:, None]


def tint(base, value, amount):
    """An RGBA image of colour `base` (0-255) varied by `value` (h x w in [0, 1])."""
    c = np.array(base, dtype=float)[None, None, :] * (1 - amount + 2 * amount * value[..., None])
    out = np.concatenate([np.clip(c, 0, 255), np.full(value.shape + (1,), 255.0)], axis=2)
    return out.astype(np.uint8)


def stone(size, base, seed):
    return tint(base, 0.6 * noise(size, seed, 8) + 0.4 * noise(size, seed + 1, 32), 0.18)


def bricks(size, base, mortar, seed, rows=8, cols=4):
    img = stone(size, base, seed)
    y, x = np.mgrid[0:size, 0:size]
    row = y * rows // size
    shift = (row % 2) * size // (2 * cols)
    joint = ((y * rows) % size < size // 32) | (((x + shift) * cols) % size < size // 48)
    img[joint] = list(mortar) + [255]
    return img


def tiles(size, a, b, seed, cells=4):
    y, x = np.mgrid[0:size, 0:size]
    light = ((x * cells // size) + (y * cells // size)) % 2 == 0
    img = np.where(light[..., None], stone(size, a, seed), stone(size, b, seed + 5))
    grout = ((x * cells) % size < 3) | ((y * cells) % size < 3)
    img[grout] = [90, 85, 80, 255]
    return img


def planks(size, base, seed, boards=6):
    y, x = np.mgrid[0:size, 0:size]
    grain = noise(size, seed, 4)[:, :1] * 0.5 + 0.5 * np.sin(x / size * 60 + 8 * noise(size, seed, 8))
    img = tint(base, np.clip(0.5 + 0.3 * grain, 0, 1), 0.25)
    img[(y * boards) % size < 2] = [50, 35, 20, 255]
    return img


def fabric(size, base, emblem, seed):
    y, x = np.mgrid[0:size, 0:size]
    weave = 0.5 + 0.25 * np.sin(x * 1.7) * np.sin(y * 1.7) + 0.25 * noise(size, seed, 16)
    img = tint(base, weave, 0.2)
    # An emblem (a ring) and a border; the bottom edge cut into a fringe of triangles.
    r = np.hypot(x - size / 2, y - size * 0.45) / size
    img[(r > 0.18) & (r < 0.24)] = list(emblem) + [255]
    border = (x < size // 16) | (x >= size - size // 16) | (y < size // 16)
    img[border] = list(emblem) + [255]
    tooth = size // 8
    fringe = y > size - tooth + np.abs((x % tooth) - tooth / 2) * 2 - tooth / 2
    img[fringe & (y > size - tooth)] = [0, 0, 0, 0]
    return img


def leaves(size, seed):
    rng = np.random.default_rng(seed)
    img = np.zeros((size, size, 4), dtype=np.uint8)
    y, x = np.mgrid[0:size, 0:size]
    for _ in range(40):
        cx, cy = rng.random(2) * size
        a = rng.random() * math.pi
        length, width = size * (0.12 + 0.1 * rng.random()), size * (0.035 + 0.02 * rng.random())
        u = (x - cx) * math.cos(a) + (y - cy) * math.sin(a)
        v = -(x - cx) * math.sin(a) + (y - cy) * math.cos(a)
        inside = (u / length) ** 2 + (v / width) ** 2 < 1
        g = 80 + int(90 * rng.random())
        img[inside] = [30 + g // 4, g, 25, 255]
    return img


def balusters(size, base, seed):
    img = stone(size, base, seed)
    y, x = np.mgrid[0:size, 0:size]
    # Rails at the top and bottom, bellied balusters between; the rest is open.
    rail = (y < size // 8) | (y >= size - size // 8)
    t = (y - size / 8) / (size * 0.75)
    belly = size / 16 * (1 + 0.8 * np.sin(np.clip(t, 0, 1) * math.pi))
    post = np.abs((x % (size // 4)) - size / 8) < belly
    img[~(rail | post)] = [0, 0, 0, 0]
    return img


def texture_set(size):
    return {
        "floor_tiles": tiles(size, (200, 190, 170), (120, 100, 85), 1),
        "gallery_floor": tiles(size, (170, 150, 120), (150, 130, 100), 3, cells=8),
        "wall_bricks": bricks(size, (170, 120, 90), (200, 190, 175), 5),
        "wall_plaster": stone(size, (215, 205, 185), 7),
        "upper_plaster": stone(size, (225, 200, 160), 9),
        "column_stone": stone(size, (205, 195, 175), 11),
        "capital_stone": stone(size, (190, 180, 160), 13),
        "base_stone": stone(size, (150, 145, 135), 15),
        "arch_stone": bricks(size, (185, 170, 145), (150, 140, 125), 17, rows=4, cols=2),
        "ceiling_wood": planks(size, (120, 80, 50), 19),
        "door_wood": planks(size, (90, 60, 40), 21, boards=10),
        "roof_edge": bricks(size, (150, 70, 50), (120, 100, 90), 23, rows=12, cols=6),
        "banner_red": fabric(size, (160, 25, 25), (220, 180, 60), 25),
        "banner_green": fabric(size, (30, 110, 50), (230, 220, 200), 27),
        "banner_blue": fabric(size, (30, 50, 140), (220, 180, 60), 29),
        "leaves": leaves(size, 31),
        "pot_terracotta": stone(size, (175, 90, 55), 33),
        "soil": stone(size, (70, 50, 35), 35),
        "balustrade": balusters(size, (200, 190, 170), 37),
        "plinth_marble": tiles(size, (230, 225, 215), (200, 195, 185), 39, cells=2),
        "lantern_metal": stone(size, (60, 55, 50), 41),
        "mosaic": tiles(size, (60, 90, 140), (200, 170, 80), 43, cells=16),
        "stair_stone": bricks(size, (160, 155, 145), (120, 115, 110), 45, rows=4, cols=1),
        "fountain_stone": stone(size, (180, 185, 190), 47),
    }


# ---- geometry -------------------------------------------------------------------------------

class Geometry:
    """Triangles of one material: positions, normals, uvs, indices."""

    def __init__(self):
        self.p, self.n, self.uv, self.i = [], [], [], []
        self.count = 0

    def add(self, p, n, uv, i):
        self.p.append(np.asarray(p, dtype=np.float32).reshape(-1, 3))
        self.n.append(np.asarray(n, dtype=np.float32).reshape(-1, 3))
        self.uv.append(np.asarray(uv, dtype=np.float32).reshape(-1, 2))
        self.i.append(np.asarray(i, dtype=np.uint32).reshape(-1) + self.count)
        self.count += self.p[-1].shape[0]

    def quad(self, o, u, v, uv_scale=(1.0, 1.0)):
        o, u, v = (np.asarray(a, dtype=float) for a in (o, u, v))
        n = np.cross(u, v)
        n /= np.linalg.norm(n)
        su, sv = uv_scale
        self.add([o, o + u, o + u + v, o + v], [n] * 4,
                 [(0, sv), (su, sv), (su, 0), (0, 0)], [0, 1, 2, 0, 2, 3])

    def box(self, lo, hi, uv_per_metre=1.0):
        lo, hi = np.asarray(lo, float), np.asarray(hi, float)
        d = hi - lo
        x, y, z = np.eye(3)
        for o, u, v in [((lo[0], lo[1], hi[2]), x * d[0], y * d[1]),   # +z
                        ((hi[0], lo[1], lo[2]), -x * d[0], y * d[1]),  # -z
                        ((hi[0], lo[1], hi[2]), -z * d[2], y * d[1]),  # +x
                        ((lo[0], lo[1], lo[2]), z * d[2], y * d[1]),   # -x
                        ((lo[0], hi[1], hi[2]), x * d[0], -z * d[2]),  # +y
                        ((lo[0], lo[1], lo[2]), x * d[0], z * d[2])]:  # -y
            self.quad(o, u, v, (np.linalg.norm(u) * uv_per_metre, np.linalg.norm(v) * uv_per_metre))

    def lathe(self, centre, profile, segments, flutes=0, flute_depth=0.0, uv_v=1.0):
        """A surface of revolution about the vertical through `centre`: profile [(r, y), ...]."""
        c = np.asarray(centre, float)
        theta = np.linspace(0, 2 * math.pi, segments + 1)
        prof = np.asarray(profile, float)
        rows = len(prof)
        r = prof[:, 0][:, None] * (1 - flute_depth * (0.5 - 0.5 * np.cos(flutes * theta)))[None, :]
        y = np.repeat(prof[:, 1][:, None], segments + 1, axis=1)
        px = c[0] + r * np.cos(theta)[None, :]
        pz = c[2] + r * np.sin(theta)[None, :]
        pos = np.stack([px, c[1] + y, pz], axis=-1)
        # Normals from the grid's tangents (outwards).
        dt = np.gradient(pos, axis=1)
        dp = np.gradient(pos, axis=0)
        n = np.cross(dp, dt)
        n /= np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-12)
        uv = np.stack(np.meshgrid(theta / (2 * math.pi) * 4, prof[:, 1] * uv_v), axis=-1)
        k = np.arange(rows - 1)[:, None] * (segments + 1) + np.arange(segments)[None, :]
        a, b, cc, d = k, k + 1, k + segments + 2, k + segments + 1
        # Counter-clockwise from outside.
        idx = np.stack([a, cc, b, a, d, cc], axis=-1).reshape(-1)
        self.add(pos.reshape(-1, 3), n.reshape(-1, 3), uv.reshape(-1, 2), idx)

    def arch(self, centre, radius, thickness, depth, segments, axis):
        """A semicircular arch band in the vertical plane along `axis` (0: x, 2: z)."""
        c = np.asarray(centre, float)
        t = np.linspace(0, math.pi, segments + 1)
        along = np.eye(3)[axis]
        across = np.eye(3)[2 - axis]
        up = np.array([0.0, 1.0, 0.0])
        for r, sign in ((radius, -1.0), (radius + thickness, 1.0)):
            # The intrados (facing the opening, inwards) and the extrados.
            for s in range(segments):
                p0 = c + r * (math.cos(t[s]) * along + math.sin(t[s]) * up)
                p1 = c + r * (math.cos(t[s + 1]) * along + math.sin(t[s + 1]) * up)
                d = across * depth / 2
                n0 = sign * (math.cos(t[s]) * along + math.sin(t[s]) * up)
                n1 = sign * (math.cos(t[s + 1]) * along + math.sin(t[s + 1]) * up)
                quad = [p0 - d, p1 - d, p1 + d, p0 + d]
                order = [0, 1, 2, 0, 2, 3] if sign > 0 else [0, 2, 1, 0, 3, 2]
                if axis == 2:
                    order = [0, 2, 1, 0, 3, 2] if sign > 0 else [0, 1, 2, 0, 2, 3]
                self.add(quad, [n0, n1, n1, n0], [(s / segments * 3, 0), ((s + 1) / segments * 3, 0),
                                                  ((s + 1) / segments * 3, depth),
                                                  (s / segments * 3, depth)], order)
        # The two faces of the band (front and back), as fans between the curves.
        for face in (-1.0, 1.0):
            d = across * depth / 2 * face
            n = across * face
            for s in range(segments):
                q = [c + r * (math.cos(tt) * along + math.sin(tt) * up) + d
                     for tt, r in ((t[s], radius), (t[s + 1], radius),
                                   (t[s + 1], radius + thickness), (t[s], radius + thickness))]
                cross = np.cross(q[1] - q[0], q[2] - q[0])
                order = [0, 1, 2, 0, 2, 3] if np.dot(cross, n) > 0 else [0, 2, 1, 0, 3, 2]
                self.add(q, [n] * 4, [(p[0 if axis == 0 else 2], p[1]) for p in q], order)


# ---- the scene ------------------------------------------------------------------------------

W, D = 30.0, 12.0       # courtyard, x and z
BAY = 3.0               # column spacing
AISLE = 4.0             # arcade depth
STOREY = 6.0            # ground floor height
H = 2 * STOREY + 1.0    # walls


def build():
    g = {name: Geometry() for name in [
        "floor", "gallery_floor", "wall", "upper_wall", "outer_wall", "column", "capital", "base",
        "arch", "ceiling", "door", "roof_edge", "banner_red", "banner_green", "banner_blue",
        "leaves", "pot", "soil", "balustrade", "plinth", "lantern", "lantern_glow", "mosaic",
        "stair", "fountain"]}
    x0, x1 = -W / 2, W / 2
    z0, z1 = -D / 2, D / 2
    zo0, zo1 = z0 - AISLE, z1 + AISLE
    # Courtyard and arcade floors, the mosaic in the middle.
    g["floor"].quad((x0, 0, zo1), (W, 0, 0), (0, 0, -(D + 2 * AISLE)), (W / 2, (D + 2 * AISLE) / 2))
    g["mosaic"].quad((-3, 0.005, 3), (6, 0, 0), (0, 0, -6), (1, 1))
    # The fountain: a basin (lathe) in the middle.
    g["fountain"].lathe((0, 0, 0), [(1.6, 0), (1.7, 0.1), (1.7, 0.6), (1.5, 0.65), (1.45, 0.3),
                                    (0.35, 0.3), (0.3, 1.4), (0.6, 1.5), (0.05, 1.55)], 96)
    # Outer walls of the arcades (facing in), end walls, and the upper storey's walls.
    g["outer_wall"].quad((x0, 0, zo0), (W, 0, 0), (0, H, 0), (W / 4, H / 4))
    g["outer_wall"].quad((x1, 0, zo1), (-W, 0, 0), (0, H, 0), (W / 4, H / 4))
    g["wall"].quad((x0, 0, zo1), (0, 0, -(D + 2 * AISLE)), (0, H, 0), ((D + 2 * AISLE) / 4, H / 4))
    g["wall"].quad((x1, 0, zo0), (0, 0, D + 2 * AISLE), (0, H, 0), ((D + 2 * AISLE) / 4, H / 4))
    # Doors in the end walls.
    for x, s in ((x0 + 0.02, 1.0), (x1 - 0.02, -1.0)):
        g["door"].quad((x, 0, s * 1.2), (0, 0, -s * 2.4), (0, 3.5, 0), (1, 1))
    # Gallery floors (the first floor over the arcades), their ceilings below, and the roof edge.
    for za, zb in ((zo0, z0), (z1, zo1)):
        g["gallery_floor"].quad((x0, STOREY, zb), (W, 0, 0), (0, 0, za - zb), (W / 2, AISLE / 2))
        g["ceiling"].quad((x0, STOREY - 0.01, za), (W, 0, 0), (0, 0, zb - za), (W / 2, AISLE / 2))
        g["ceiling"].quad((x0, H - 0.01, za), (W, 0, 0), (0, 0, zb - za), (W / 2, AISLE / 2))
        g["roof_edge"].box((x0, H, min(za, zb)), (x1, H + 0.6, max(za, zb)), 0.5)
    # Upper wall above the upper arches on each side (courtyard face).
    for z, s in ((z0, 1.0), (z1, -1.0)):
        g["upper_wall"].quad((x0 if s > 0 else x1, 2 * STOREY, z), (s * W, 0, 0),
                             (0, H - 2 * STOREY, 0), (W / 4, 0.5))
    # Columns, arches, balustrades, banners, plants and lanterns along both arcades.
    n_bays = int(W / BAY)
    # Shaft from the base (0.4 m) to the capital (4.0 m): a slight entasis, 40 rings.
    column_profile = [(0.3 + 0.035 * math.sin(math.pi * (0.15 + 0.85 * t)) - 0.03 * t, 3.6 * t)
                      for t in np.linspace(0.0, 1.0, 40)]
    for side, z in ((0, z0), (1, z1)):
        facing = 1.0 if side == 0 else -1.0   # towards the courtyard
        for k in range(n_bays + 1):
            x = x0 + k * BAY
            for storey in range(2):
                y0 = storey * STOREY
                g["base"].box((x - 0.5, y0, z - 0.5), (x + 0.5, y0 + 0.4, z + 0.5), 1.0)
                g["column"].lathe((x, y0 + 0.4, z), column_profile, 96, flutes=16,
                                  flute_depth=0.06, uv_v=0.5)
                g["capital"].lathe((x, y0 + 4.0, z), [(0.27, 0.0), (0.3, 0.1), (0.38, 0.25),
                                                      (0.46, 0.45), (0.46, 0.6)], 64)
                g["capital"].box((x - 0.55, y0 + 4.6, z - 0.55), (x + 0.55, y0 + 4.8, z + 0.55))
            if k < n_bays:
                for storey in range(2):
                    y0 = storey * STOREY
                    # Springing from the abaci at 4.8 m, the crown at the storey's top.
                    g["arch"].arch((x + BAY / 2, y0 + 4.8, z), BAY / 2 - 0.55, 0.25, 1.0, 48, 0)
                # Balustrade between the upper columns; a banner under every other upper arch.
                g["balustrade"].quad((x + 0.5, STOREY, z + facing * 0.3), (BAY - 1.0, 0, 0),
                                     (0, 1.0, 0), (2, 1))
                if k % 2 == 1:
                    colour = ("banner_red", "banner_green", "banner_blue")[(k // 2 + side) % 3]
                    g[colour].quad((x + 0.7, STOREY + 0.8, z + facing * 0.6), (BAY - 1.4, 0, 0),
                                   (0, 3.2, 0), (1, 1))
                # A lantern hanging in the middle of each ground-floor bay.
                lx, lz = x + BAY / 2, z - facing * AISLE / 2
                g["lantern"].box((lx - 0.02, 4.2, lz - 0.02), (lx + 0.02, STOREY, lz + 0.02), 1.0)
                g["lantern"].box((lx - 0.22, 3.55, lz - 0.22), (lx + 0.22, 3.6, lz + 0.22), 2.0)
                g["lantern"].box((lx - 0.22, 4.15, lz - 0.22), (lx + 0.22, 4.2, lz + 0.22), 2.0)
                g["lantern_glow"].box((lx - 0.18, 3.6, lz - 0.18), (lx + 0.18, 4.15, lz + 0.18), 1.0)
        # Potted plants along the courtyard side of the arcade.
        for k in range(0, n_bays, 2):
            px, pz = x0 + (k + 0.5) * BAY, z + facing * 1.2
            g["pot"].lathe((px, 0, pz), [(0.25, 0.0), (0.4, 0.5), (0.45, 0.7), (0.42, 0.72)], 48)
            g["soil"].quad((px - 0.3, 0.66, pz + 0.3), (0.6, 0, 0), (0, 0, -0.6), (1, 1))
            rng = np.random.default_rng(int(k * 7 + side))
            for leaf in range(24):
                a = rng.random() * math.pi
                h = 0.7 + rng.random() * 1.1
                size = 0.6 + rng.random() * 0.5
                u = np.array([math.cos(a), 0.0, math.sin(a)]) * size
                o = np.array([px, h, pz]) - u / 2
                tilt = np.array([0.0, size * 0.9, 0.0]) + np.cross(u, [0, 1, 0]) * 0.3
                g["leaves"].quad(o, u, tilt, (1, 1))
                g["leaves"].quad(o + u, -u, tilt, (1, 1))  # two-sided cards, both windings
        # A plinth and stair at each end of the arcade.
        for x in (x0 + 1.0, x1 - 3.0):
            g["plinth"].box((x, 0, z - facing * 1.5 - 0.6), (x + 2.0, 0.9, z - facing * 1.5 + 0.6))
            for step in range(6):
                g["stair"].box((x, 0.9 + 0.18 * step, z - facing * 3.3 - 0.4),
                               (x + 2.0, 1.08 + 0.18 * step, z - facing * 3.3 + 0.4 - 0.1 * step))
    return g


MATERIALS = {
    # name: (texture, uv scale for KHR_texture_transform or None, extras)
    "floor": ("floor_tiles", None, {}),
    "gallery_floor": ("gallery_floor", None, {}),
    "wall": ("wall_bricks", None, {}),
    "upper_wall": ("upper_plaster", None, {}),
    "outer_wall": ("wall_plaster", (0.5, 0.5), {}),
    "column": ("column_stone", None, {}),
    "capital": ("capital_stone", None, {}),
    "base": ("base_stone", None, {}),
    "arch": ("arch_stone", None, {}),
    "ceiling": ("ceiling_wood", None, {}),
    "door": ("door_wood", None, {}),
    "roof_edge": ("roof_edge", None, {}),
    "banner_red": ("banner_red", None, {"alphaMode": "MASK", "doubleSided": True}),
    "banner_green": ("banner_green", None, {"alphaMode": "MASK", "doubleSided": True}),
    "banner_blue": ("banner_blue", None, {"alphaMode": "MASK", "doubleSided": True}),
    "leaves": ("leaves", None, {"alphaMode": "MASK", "alphaCutoff": 0.5, "doubleSided": True}),
    "pot": ("pot_terracotta", None, {}),
    "soil": ("soil", None, {}),
    "balustrade": ("balustrade", None, {"alphaMode": "MASK", "doubleSided": True}),
    "plinth": ("plinth_marble", None, {}),
    "lantern": ("lantern_metal", None, {}),
    "mosaic": ("mosaic", (2.0, 2.0), {}),
    "stair": ("stair_stone", None, {}),
    "fountain": ("fountain_stone", None, {}),
}


def look_rotation(forward):
    """The glTF node rotation (x, y, z, w) whose local -z is `forward` and local +y is as near
    world +y as it can be."""
    back = -np.asarray(forward, float)
    back /= np.linalg.norm(back)
    right = np.cross([0.0, 1.0, 0.0], back)
    if np.linalg.norm(right) < 1e-6:
        right = np.array([1.0, 0.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(back, right)
    m = np.stack([right, up, back], axis=1)  # columns: the local axes in world space
    w = math.sqrt(max(0.0, 1.0 + m[0, 0] + m[1, 1] + m[2, 2])) / 2
    x = math.copysign(math.sqrt(max(0.0, 1.0 + m[0, 0] - m[1, 1] - m[2, 2])) / 2, m[2, 1] - m[1, 2])
    y = math.copysign(math.sqrt(max(0.0, 1.0 - m[0, 0] + m[1, 1] - m[2, 2])) / 2, m[0, 2] - m[2, 0])
    z = math.copysign(math.sqrt(max(0.0, 1.0 - m[0, 0] - m[1, 1] + m[2, 2])) / 2, m[1, 0] - m[0, 1])
    return [x, y, z, w]


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "atrium.glb"
    size = 256
    textures = texture_set(size)
    geometry = build()
    binary = bytearray()
    doc = {
        "asset": {"generator": "Penumbra scenes/atrium/make_atrium.py", "version": "2.0"},
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_emissive_strength",
                           "KHR_texture_transform"],
        "scene": 0, "scenes": [{"name": "Atrium", "nodes": []}],
        "nodes": [], "meshes": [], "materials": [], "textures": [], "images": [],
        "samplers": [{"magFilter": 9729, "minFilter": 9987}], "accessors": [], "bufferViews": [],
    }

    def view(data, target=None):
        while len(binary) % 4:
            binary.append(0)
        v = {"buffer": 0, "byteOffset": len(binary), "byteLength": len(data)}
        if target:
            v["target"] = target
        binary.extend(data)
        doc["bufferViews"].append(v)
        return len(doc["bufferViews"]) - 1

    def accessor(array, kind, component):
        a = {"bufferView": view(array.tobytes(), 34963 if kind == "SCALAR" else 34962),
             "componentType": component, "count": int(array.shape[0]), "type": kind}
        if kind == "VEC3":
            a["min"] = [float(v) for v in array.min(axis=0)]
            a["max"] = [float(v) for v in array.max(axis=0)]
        doc["accessors"].append(a)
        return len(doc["accessors"]) - 1

    image_index = {}
    for name, img in textures.items():
        doc["images"].append({"name": name, "mimeType": "image/png", "bufferView": view(png(img))})
        doc["textures"].append({"sampler": 0, "source": len(doc["images"]) - 1})
        image_index[name] = len(doc["textures"]) - 1

    triangles = 0
    for name, geo in geometry.items():
        if geo.count == 0:
            continue
        if name == "lantern_glow":
            material = {"name": "lantern_glow", "emissiveFactor": [1.0, 0.75, 0.45],
                        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 40.0}},
                        "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.85, 0.7, 1.0],
                                                 "metallicFactor": 0.0}}
        else:
            tex, scale, extra = MATERIALS[name]
            info = {"index": image_index[tex]}
            if scale:
                info["extensions"] = {"KHR_texture_transform": {"scale": list(scale)}}
            material = {"name": name, "pbrMetallicRoughness": {
                "baseColorTexture": info, "metallicFactor": 0.0, "roughnessFactor": 0.8}}
            material["doubleSided"] = True
            material.update(extra)
        doc["materials"].append(material)
        p = np.concatenate(geo.p).astype(np.float32)
        n = np.concatenate(geo.n).astype(np.float32)
        uv = np.concatenate(geo.uv).astype(np.float32)
        idx = np.concatenate(geo.i).astype(np.uint32)
        triangles += idx.shape[0] // 3
        prim = {"attributes": {"POSITION": accessor(p, "VEC3", 5126),
                               "NORMAL": accessor(n, "VEC3", 5126),
                               "TEXCOORD_0": accessor(uv, "VEC2", 5126)},
                "indices": accessor(idx, "SCALAR", 5125), "material": len(doc["materials"]) - 1}
        doc["meshes"].append({"name": name, "primitives": [prim]})
        doc["nodes"].append({"name": name, "mesh": len(doc["meshes"]) - 1})
        doc["scenes"][0]["nodes"].append(len(doc["nodes"]) - 1)

    # The sun: 100,000 lx from high in the south-west, through the open roof.
    elevation, azimuth = math.radians(62), math.radians(35)
    d = np.array([math.cos(elevation) * math.sin(azimuth), math.sin(elevation),
                  math.cos(elevation) * math.cos(azimuth)])  # towards the sun
    doc["extensions"] = {"KHR_lights_punctual": {"lights": [
        {"name": "Sun", "type": "directional", "color": [1.0, 0.96, 0.9], "intensity": 100000.0}]}}
    doc["nodes"].append({"name": "Sun", "rotation": look_rotation(-d),
                         "extensions": {"KHR_lights_punctual": {"light": 0}}})
    doc["scenes"][0]["nodes"].append(len(doc["nodes"]) - 1)
    doc["cameras"] = [{"name": "Camera", "type": "perspective",
                       "perspective": {"aspectRatio": 1.5, "yfov": 1.0, "znear": 0.1, "zfar": 200}}]
    # From the west end of the courtyard, looking east and a little up.
    doc["nodes"].append({"name": "Camera", "camera": 0, "translation": [-13.0, 1.7, 0.8],
                         "rotation": look_rotation([1.0, 0.18, 0.05])})
    doc["scenes"][0]["nodes"].append(len(doc["nodes"]) - 1)

    while len(binary) % 4:
        binary.append(0)
    doc["buffers"] = [{"byteLength": len(binary)}]
    text = json.dumps(doc, separators=(",", ":"), sort_keys=True).encode()
    while len(text) % 4:
        text += b" "
    with open(out, "wb") as f:
        f.write(struct.pack("<III", 0x46546C67, 2, 12 + 8 + len(text) + 8 + len(binary)))
        f.write(struct.pack("<II", len(text), 0x4E4F534A) + text)
        f.write(struct.pack("<II", len(binary), 0x004E4942) + bytes(binary))
    print(f"{out}: {triangles} triangles, {len(textures)} textures, {len(doc['materials'])} materials")


if __name__ == "__main__":
    main()
