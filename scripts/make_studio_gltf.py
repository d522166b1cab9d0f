#!/usr/bin/env python3
"""Writes scenes/studio.gltf: a small room as a glTF 2.0 exporter (Blender's) writes one.

Walls, floor and ceiling are single quads (two triangles each), nodes carry the transforms
(a rotated, scaled box under a parent node), the ceiling panel is an emissive material with
KHR_materials_emissive_strength, a KHR_lights_punctual spot light hangs from the ceiling, the
box's material is doubleSided, and the camera is a node. One embedded buffer (data URI), so
the scene is one file. Run from the repository root: python3 scripts/make_studio_gltf.py
"""
import base64
import json
import math
import struct

positions, normals, indices = [], [], []
meshes = []


def add_mesh(name, quads):
    """quads: list of (corner0..3, normal); corners counter-clockwise seen from the front."""
    first_index = len(indices)
    first_vertex = len(positions)
    for corners, n in quads:
        base = len(positions) - first_vertex
        positions.extend(corners)
        normals.extend([n] * 4)
        indices.extend([base, base + 1, base + 2, base, base + 2, base + 3])
    meshes.append((name, first_vertex, len(positions) - first_vertex, first_index,
                   len(indices) - first_index))
    return len(meshes) - 1


W, H, D = 4.0, 2.8, 5.0  # x, y (up), z
room = add_mesh("room", [
    ([(0, 0, 0), (0, 0, D), (W, 0, D), (W, 0, 0)], (0, 1, 0)),          # floor
    ([(0, H, 0), (W, H, 0), (W, H, D), (0, H, D)], (0, -1, 0)),         # ceiling
    ([(0, 0, 0), (W, 0, 0), (W, H, 0), (0, H, 0)], (0, 0, 1)),          # back wall
    ([(0, 0, D), (0, H, D), (W, H, D), (W, 0, D)], (0, 0, -1)),         # front wall
    ([(0, 0, 0), (0, H, 0), (0, H, D), (0, 0, D)], (1, 0, 0)),          # left wall
    ([(W, 0, 0), (W, 0, D), (W, H, D), (W, H, 0)], (-1, 0, 0)),         # right wall
])
# A unit cube centred at the origin, faces outwards.
cube_faces = []
for axis in range(3):
    for sign in (-1, 1):
        n = [0, 0, 0]
        n[axis] = sign
        u = [0, 0, 0]
        v = [0, 0, 0]
        u[(axis + 1) % 3] = 1
        v[(axis + 2) % 3] = 1
        if sign < 0:
            u, v = v, u
        c = [0.5 * sign * (axis == k) for k in range(3)]
        corners = []
        for a, b in ((-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)):
            corners.append(tuple(c[k] + a * u[k] + b * v[k] for k in range(3)))
        cube_faces.append((corners, tuple(n)))
cube = add_mesh("box", cube_faces)
panel = add_mesh("panel", [([(-0.5, 0, -0.5), (0.5, 0, -0.5), (0.5, 0, 0.5), (-0.5, 0, 0.5)],
                            (0, -1, 0))])

blob = bytearray()
for p in positions:
    blob += struct.pack("<3f", *p)
normal_offset = len(blob)
for n in normals:
    blob += struct.pack("<3f", *n)
index_offset = len(blob)
for i in indices:
    blob += struct.pack("<I", i)

accessors, views = [], [
    {"buffer": 0, "byteOffset": 0, "byteLength": normal_offset, "target": 34962},
    {"buffer": 0, "byteOffset": normal_offset, "byteLength": index_offset - normal_offset,
     "target": 34962},
    {"buffer": 0, "byteOffset": index_offset, "byteLength": len(blob) - index_offset,
     "target": 34963},
]
gltf_meshes = []
materials_of = {room: 0, cube: 1, panel: 2}
for m, (name, v0, nv, i0, ni) in enumerate(meshes):
    pts = positions[v0:v0 + nv]
    lo = [min(p[k] for p in pts) for k in range(3)]
    hi = [max(p[k] for p in pts) for k in range(3)]
    accessors.append({"bufferView": 0, "byteOffset": 12 * v0, "componentType": 5126,
                      "count": nv, "type": "VEC3", "min": lo, "max": hi})
    accessors.append({"bufferView": 1, "byteOffset": 12 * v0, "componentType": 5126,
                      "count": nv, "type": "VEC3"})
    accessors.append({"bufferView": 2, "byteOffset": 4 * i0, "componentType": 5125,
                      "count": ni, "type": "SCALAR"})
    # Indices are relative to the mesh's own first vertex (the accessor's offset).
    gltf_meshes.append({"name": name, "primitives": [{
        "attributes": {"POSITION": 3 * m, "NORMAL": 3 * m + 1}, "indices": 3 * m + 2,
        "material": materials_of[m]}]})


def quat_y(degrees):
    a = math.radians(degrees) / 2
    return [0.0, math.sin(a), 0.0, math.cos(a)]


def quat_x(degrees):
    a = math.radians(degrees) / 2
    return [math.sin(a), 0.0, 0.0, math.cos(a)]


gltf = {
    "asset": {"version": "2.0", "generator": "penumbra scripts/make_studio_gltf.py"},
    "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_emissive_strength"],
    "extensions": {"KHR_lights_punctual": {"lights": [
        {"name": "spot", "type": "spot", "color": [1.0, 0.9, 0.75], "intensity": 3000.0,
         "spot": {"innerConeAngle": 0.35, "outerConeAngle": 0.6}}]}},
    "scene": 0,
    "scenes": [{"name": "studio", "nodes": [0, 1, 3, 4, 5]}],
    "nodes": [
        {"name": "room", "mesh": room},
        {"name": "furniture", "translation": [1.3, 0.0, 2.0], "rotation": quat_y(25),
         "children": [2]},
        {"name": "box", "mesh": cube, "translation": [0.0, 0.45, 0.0], "scale": [0.9, 0.9, 0.9]},
        {"name": "ceiling panel", "mesh": panel, "translation": [2.6, H - 0.01, 3.2]},
        # Spot lights shine down their node's -z axis: turned to point at the floor.
        {"name": "spot", "translation": [2.8, H - 0.05, 1.6], "rotation": quat_x(-90),
         "extensions": {"KHR_lights_punctual": {"light": 0}}},
        # The camera looks down its node's -z axis: from the front wall into the room.
        {"name": "camera", "camera": 0, "translation": [2.0, 1.4, D - 0.1],
         "rotation": quat_x(-8)},
    ],
    "cameras": [{"type": "perspective", "perspective": {
        "yfov": 1.0, "aspectRatio": 4 / 3, "znear": 0.05, "zfar": 100.0}}],
    "materials": [
        {"name": "plaster", "pbrMetallicRoughness": {
            "baseColorFactor": [0.75, 0.72, 0.68, 1.0], "metallicFactor": 0.0}},
        {"name": "painted wood", "doubleSided": True, "pbrMetallicRoughness": {
            "baseColorFactor": [0.6, 0.25, 0.15, 1.0], "metallicFactor": 0.0}},
        {"name": "panel", "emissiveFactor": [1.0, 0.95, 0.85],
         "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 8.0}},
         "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0],
                                  "metallicFactor": 0.0}},
    ],
    "meshes": gltf_meshes,
    "accessors": accessors,
    "bufferViews": views,
    "buffers": [{"byteLength": len(blob),
                 "uri": "data:application/octet-stream;base64," +
                        base64.b64encode(bytes(blob)).decode()}],
}
with open("scenes/studio.gltf", "w") as f:
    json.dump(gltf, f, indent=1)
    f.write("\n")
