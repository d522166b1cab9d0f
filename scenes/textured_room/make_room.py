#!/usr/bin/env python3
"""Writes room.glb: a small textured room as Blender's glTF exporter writes one.

A 4 x 2.6 x 4 m room lit by an emissive ceiling panel, with
  - a chequered floor (baseColorTexture; baseColorFactor left at its default of 1, as Blender
    leaves it wherever a texture gives the colour),
  - a striped painting on the back wall whose texture reads the second UV set (TEXCOORD_1),
  - an emissive screen on the left wall whose colours come from a texture (emissiveTexture,
    emissiveFactor 1 and KHR_materials_emissive_strength),
  - an alpha-masked lattice under the panel (alphaMode MASK, alphaCutoff 0.5, doubleSided),
  - plain walls and ceiling (baseColorFactor only).
Textures are PNGs embedded in buffer views with the sampler Blender writes (LINEAR /
LINEAR_MIPMAP_LINEAR, REPEAT). Only the standard library is used; the output is the same bytes
on every run.

Usage: make_room.py [OUTPUT]   (default: room.glb beside this script)
"""

import json
import os
import struct
import sys
import zlib


def png(width, height, rgba):
    """An 8-bit RGBA PNG of `rgba` (bytes, row 0 at the top)."""

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)

    raw = b"".join(b"\0" + rgba[y * width * 4:(y + 1) * width * 4] for y in range(height))
    header = struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, 9)) +
            chunk(b"IEND", b""))


def image(width, height, texel):
    """Bytes of an RGBA image whose texel (x, y) is texel(x, y) -> (r, g, b, a)."""
    out = bytearray()
    for y in range(height):
        for x in range(width):
            out += bytes(texel(x, y))
    return bytes(out)


def chequer_texture():
    light, dark = (205, 190, 160, 255), (70, 55, 45, 255)
    return png(256, 256, image(256, 256, lambda x, y: light if (x // 32 + y // 32) % 2 == 0 else dark))


def stripes_texture():
    colours = [(200, 40, 30, 255), (230, 200, 60, 255), (40, 70, 170, 255), (235, 235, 225, 255)]
    return png(128, 128, image(128, 128, lambda x, y: colours[(x // 16) % 4]))


def screen_texture():
    bands = [(255, 20, 20, 255), (20, 255, 20, 255), (20, 20, 255, 255)]
    return png(96, 64, image(96, 64, lambda x, y: bands[min(x // 32, 2)]))


def lattice_texture():
    # Bars 8 texels wide every 32 texels: about 44% of the lattice is solid.
    def texel(x, y):
        solid = x % 32 < 8 or y % 32 < 8
        return (180, 150, 110, 255) if solid else (180, 150, 110, 0)

    return png(128, 128, image(128, 128, texel))


class Builder:
    def __init__(self):
        self.bin = bytearray()
        self.doc = {
            "asset": {"generator": "Khronos glTF Blender I/O v3.6.28", "version": "2.0"},
            "extensionsUsed": ["KHR_materials_emissive_strength"],
            "scene": 0,
            "scenes": [{"name": "Scene", "nodes": []}],
            "nodes": [], "meshes": [], "materials": [], "textures": [], "images": [],
            "samplers": [{"magFilter": 9729, "minFilter": 9987}],
            "accessors": [], "bufferViews": [], "buffers": [],
        }

    def view(self, data, target=None):
        while len(self.bin) % 4:
            self.bin += b"\0"
        v = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)}
        if target:
            v["target"] = target
        self.bin += data
        self.doc["bufferViews"].append(v)
        return len(self.doc["bufferViews"]) - 1

    def accessor(self, values, kind, component=5126):
        width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3}[kind]
        fmt = "<" + ("f" if component == 5126 else "H") * (len(values) * width)
        flat = [c for v in values for c in (v if width > 1 else (v,))]
        view = self.view(struct.pack(fmt, *flat), 34963 if component == 5123 else 34962)
        a = {"bufferView": view, "componentType": component, "count": len(values), "type": kind}
        if kind == "VEC3" and component == 5126:
            a["min"] = [min(v[i] for v in values) for i in range(3)]
            a["max"] = [max(v[i] for v in values) for i in range(3)]
        self.doc["accessors"].append(a)
        return len(self.doc["accessors"]) - 1

    def texture(self, name, data):
        view = self.view(data)
        self.doc["images"].append({"bufferView": view, "mimeType": "image/png", "name": name})
        self.doc["textures"].append({"sampler": 0, "source": len(self.doc["images"]) - 1})
        return len(self.doc["textures"]) - 1

    def material(self, m):
        self.doc["materials"].append(m)
        return len(self.doc["materials"]) - 1

    def quad(self, name, corner, u, v, material, uv_repeat=(1.0, 1.0), uv1=None):
        """A quad corner, corner + u, corner + u + v, corner + v; its front faces u x v."""
        p = [corner, add(corner, u), add(add(corner, u), v), add(corner, v)]
        n = normalise(cross(u, v))
        # glTF's v runs down the image: the quad's corner + v edge is the image's top.
        ru, rv = uv_repeat
        uv = [(0.0, rv), (ru, rv), (ru, 0.0), (0.0, 0.0)]
        attributes = {"POSITION": self.accessor(p, "VEC3"), "NORMAL": self.accessor([n] * 4, "VEC3"),
                      "TEXCOORD_0": self.accessor(uv, "VEC2")}
        if uv1 is not None:
            attributes["TEXCOORD_1"] = self.accessor(uv1, "VEC2")
        indices = self.accessor([0, 1, 2, 0, 2, 3], "SCALAR", 5123)
        self.doc["meshes"].append({"name": name, "primitives": [
            {"attributes": attributes, "indices": indices, "material": material}]})
        self.doc["nodes"].append({"mesh": len(self.doc["meshes"]) - 1, "name": name})
        self.doc["scenes"][0]["nodes"].append(len(self.doc["nodes"]) - 1)

    def write(self, path):
        while len(self.bin) % 4:
            self.bin += b"\0"
        self.doc["buffers"] = [{"byteLength": len(self.bin)}]
        text = json.dumps(self.doc, separators=(",", ":"), sort_keys=True).encode()
        while len(text) % 4:
            text += b" "
        total = 12 + 8 + len(text) + 8 + len(self.bin)
        with open(path, "wb") as f:
            f.write(struct.pack("<III", 0x46546C67, 2, total))
            f.write(struct.pack("<II", len(text), 0x4E4F534A) + text)
            f.write(struct.pack("<II", len(self.bin), 0x004E4942) + bytes(self.bin))


def add(a, b):
    return tuple(x + y for x, y in zip(a, b))


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def normalise(a):
    n = sum(x * x for x in a) ** 0.5
    return tuple(x / n for x in a)


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "room.glb")
    b = Builder()
    pbr = {"metallicFactor": 0.0, "roughnessFactor": 0.5}
    floor = b.material({"name": "Floor", "doubleSided": True, "pbrMetallicRoughness": dict(
        pbr, baseColorTexture={"index": b.texture("floor_chequer", chequer_texture())})})
    wall = b.material({"name": "Wall", "doubleSided": True, "pbrMetallicRoughness": dict(
        pbr, baseColorFactor=[0.75, 0.74, 0.7, 1.0])})
    painting = b.material({"name": "Painting", "doubleSided": True, "pbrMetallicRoughness": dict(
        pbr, baseColorTexture={"index": b.texture("stripes", stripes_texture()), "texCoord": 1})})
    screen = b.material({
        "name": "Screen", "doubleSided": True, "emissiveFactor": [1.0, 1.0, 1.0],
        "emissiveTexture": {"index": b.texture("screen_rgb", screen_texture())},
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 3.0}},
        "pbrMetallicRoughness": dict(pbr, baseColorFactor=[0.05, 0.05, 0.05, 1.0])})
    lattice = b.material({
        "name": "Lattice", "doubleSided": True, "alphaMode": "MASK", "alphaCutoff": 0.5,
        "pbrMetallicRoughness": dict(pbr, baseColorTexture={
            "index": b.texture("lattice", lattice_texture())})})
    panel = b.material({
        "name": "Panel", "emissiveFactor": [1.0, 0.95, 0.85],
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 12.0}},
        "pbrMetallicRoughness": dict(pbr, baseColorFactor=[0.8, 0.8, 0.8, 1.0])})

    w, h, d = 4.0, 2.6, 4.0
    x0, z0 = -w / 2, -d / 2
    # Floor (up), ceiling (down), back wall (towards +z), left (+x), right (-x), front (-z).
    b.quad("Floor", (x0, 0, -z0), (w, 0, 0), (0, 0, -d), floor, uv_repeat=(2.0, 2.0))
    b.quad("Ceiling", (x0, h, z0), (w, 0, 0), (0, 0, d), wall)
    b.quad("BackWall", (x0, 0, z0), (w, 0, 0), (0, h, 0), wall)
    b.quad("LeftWall", (x0, 0, -z0), (0, 0, -d), (0, h, 0), wall)
    b.quad("RightWall", (-x0, 0, z0), (0, 0, d), (0, h, 0), wall)
    b.quad("FrontWall", (-x0, 0, -z0), (-w, 0, 0), (0, h, 0), wall)
    # The painting on the back wall; its texture reads TEXCOORD_1, a second layout.
    b.quad("Painting", (-0.9, 0.9, z0 + 0.01), (1.8, 0, 0), (0, 1.2, 0), painting,
           uv1=[(0.0, 1.0), (1.0, 1.0), (1.0, 0.0), (0.0, 0.0)])
    # The screen on the left wall, facing +x.
    b.quad("Screen", (x0 + 0.01, 0.8, 0.7), (0, 0, -1.4), (0, 0.9, 0), screen)
    # The ceiling panel (facing down) and the lattice 0.5 m under it.
    b.quad("Panel", (-0.4, h - 0.01, -0.4), (0.8, 0, 0), (0, 0, 0.8), panel)
    b.quad("Lattice", (-0.8, h - 0.5, 0.8), (1.6, 0, 0), (0, 0, -1.6), lattice)
    b.doc["cameras"] = [{"name": "Camera", "type": "perspective", "perspective": {
        "aspectRatio": 1.5, "yfov": 1.0, "znear": 0.1, "zfar": 100.0}}]
    b.doc["nodes"].append({"camera": 0, "name": "Camera", "translation": [0.0, 1.3, 1.9]})
    b.doc["scenes"][0]["nodes"].append(len(b.doc["nodes"]) - 1)
    b.write(out)


if __name__ == "__main__":
    main()
