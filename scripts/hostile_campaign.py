#!/usr/bin/env python3
"""Hostile values in scene files: every value of a JSON scene and of a glTF file that uses every
kind of entry is set, one at a time, to 0, -1, 1e39, 1e300, NaN, Infinity (as Python's json
writes them), a string and an empty array, and each file is rendered by each method asked for.

The contract: no crash, no hang (a run is killed after --timeout seconds), no NaN or infinite
pixel in an image written, and no exit code but 0 (the value is fine) or 2 (one error line naming
the file). Prints a summary and every breach; exits 1 when there is one.

    scripts/hostile_campaign.py build/bin/penumbra OUT [--methods pathtrace,progressive,...]
"""
import argparse
import collections
import concurrent.futures
import copy
import json
import math
import os
import struct
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
LDT = os.path.join(ROOT, "tests", "data", "photometry", "sample_isym1.ldt")

# A room of two quads (floor and back wall, from an OBJ), a sphere, an emissive panel, a light of
# every kind, a camera, an environment and settings for every method.
SCENE = {
    "materials": {
        "white": {"reflectance": [0.8, 0.8, 0.8]},
        "lamp": {"reflectance": [0.5, 0.5, 0.5], "emission": [4, 4, 4]},
    },
    "meshes": [
        {"file": "room.obj", "material": "white",
         "transform": {"translate": [0, 0, 0], "rotate_deg": [0, 0, 0], "scale": [1, 1, 1]}},
        {"sphere": 2, "material": "white",
         "transform": {"matrix": [0.3, 0, 0, 1, 0, 0.3, 0, 0.3, 0, 0, 0.3, 1, 0, 0, 0, 1]}},
        {"file": "panel.obj", "material": "lamp", "transform": {"translate": [1, 1.99, 1]}},
    ],
    "lights": [
        {"type": "point", "position": [0.5, 1.5, 1.5], "intensity": [1, 1, 1]},
        {"type": "spot", "position": [1.5, 1.9, 1], "direction": [0, -1, 0], "intensity": [2, 2, 2],
         "inner_angle_deg": 10, "outer_angle_deg": 30},
        {"type": "directional", "direction": [0.2, -1, 0.1], "irradiance": [0.5, 0.5, 0.5]},
        {"type": "luminaire", "file": LDT, "position": [1, 1.9, 0.5], "aim": [0, -1, 0],
         "dimming": 0.5, "rotation_deg": 15, "array": {"count": [2, 1], "spacing": [0.5, 0.5]}},
    ],
    "camera": {"position": [1, 1, 3.5], "look_at": [1, 0.8, 0], "up": [0, 1, 0], "fov_deg": 50},
    "environment": [0.05, 0.05, 0.05],
    "settings": {
        "pathtrace": {"spp": 2, "max_depth": 3},
        "progressive": {"texel_density": 8, "iterations": 20},
        "stochastic": {"texel_density": 8, "iterations": 20},
        "matrix": {"elements": 200},
        "whitted": {"light_samples": 2},
    },
}

ROOM_OBJ = """v 0 0 0
v 2 0 0
v 2 0 2
v 0 0 2
v 0 2 0
v 2 2 0
f 1 4 3 2
f 1 2 6 5
"""
PANEL_OBJ = "v -0.2 0 -0.2\nv 0.2 0 -0.2\nv 0.2 0 0.2\nv -0.2 0 0.2\nf 1 2 3 4\n"


def quad_gltf():
    """A unit quad as Blender's exporter writes one (see fuzz/value_templates.h)."""
    import base64
    buf = b"".join(struct.pack("<3f", *p) for p in [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)])
    buf += b"".join(struct.pack("<3f", 0, 0, 1) for _ in range(4))
    buf += b"".join(struct.pack("<2f", *t) for t in [(0, 1), (1, 1), (1, 0), (0, 0)])
    buf += struct.pack("<6H", 0, 1, 2, 0, 2, 3)
    png = ("iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mP8z8BQDwAEhQGAhKmMIQAAAABJ"
           "RU5ErkJggg==")
    return {
        "asset": {"version": "2.0", "generator": "Khronos glTF Blender I/O"},
        "extensionsUsed": ["KHR_texture_transform", "KHR_lights_punctual",
                           "KHR_materials_emissive_strength"],
        "scene": 0, "scenes": [{"nodes": [0, 1, 2, 3]}],
        "nodes": [
            {"mesh": 0, "translation": [0, 0, 0], "rotation": [0, 0, 0, 1], "scale": [1, 1, 1]},
            {"camera": 0, "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0.5, 0.5, 3, 1]},
            {"translation": [0.5, 0.5, 1], "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"mesh": 1, "translation": [0.5, 0.5, 1.5], "scale": [0.2, 0.2, 0.2]},
        ],
        "cameras": [{"type": "perspective",
                     "perspective": {"yfov": 0.7, "aspectRatio": 1.0, "znear": 0.01, "zfar": 100}}],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "spot", "color": [1, 1, 1], "intensity": 10,
             "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.6}}]}},
        "materials": [
            {"name": "quad", "alphaMode": "MASK", "alphaCutoff": 0.5,
             "pbrMetallicRoughness": {
                 "baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0,
                 "roughnessFactor": 0.5,
                 "baseColorTexture": {"index": 0, "texCoord": 0, "extensions": {
                     "KHR_texture_transform": {"offset": [0, 0], "scale": [2, 2],
                                               "rotation": 0.1}}}}},
            {"name": "lamp", "emissiveFactor": [1, 1, 1],
             "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 5}}}],
        "textures": [{"source": 0, "sampler": 0}],
        "samplers": [{"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497}],
        "images": [{"uri": "data:image/png;base64," + png}],
        "meshes": [
            {"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2},
                             "indices": 3, "material": 0}]},
            {"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1},
                             "indices": 3, "material": 1}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 48},
            {"buffer": 0, "byteOffset": 96, "byteLength": 32},
            {"buffer": 0, "byteOffset": 128, "byteLength": 12}],
        "buffers": [{"byteLength": len(buf),
                     "uri": "data:application/octet-stream;base64," +
                            base64.b64encode(buf).decode()}],
    }


HOSTILE = [0, -1, 1e39, 1e300, float("nan"), float("inf"), "text", []]


def numeric_paths(value, path=()):
    """Paths of every number in `value` (and of every list of numbers, as a whole)."""
    if isinstance(value, bool):
        return
    if isinstance(value, (int, float)):
        yield path
    elif isinstance(value, list):
        if value and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
            yield path
        for i, v in enumerate(value):
            yield from numeric_paths(v, path + (i,))
    elif isinstance(value, dict):
        for k, v in value.items():
            yield from numeric_paths(v, path + (k,))


def replaced(doc, path, value):
    out = copy.deepcopy(doc)
    node = out
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    return out


def read_pfm(path):
    with open(path, "rb") as f:
        assert f.readline().strip() == b"PF"
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = f.read()
    fmt = ("<" if scale < 0 else ">") + "%df" % (3 * w * h)
    return struct.unpack(fmt, data[: 4 * 3 * w * h])


def run_case(cli, scene_path, method, out, timeout, device="auto"):
    image = out + ".pfm"
    args = [cli, "render", scene_path, "--method", method, "--width", "12", "--height", "10",
            "--device", device, "--quiet", "-o", image]
    started = time.monotonic()
    try:
        run = subprocess.run(args, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return "hang", time.monotonic() - started, ""
    seconds = time.monotonic() - started
    err = run.stderr.strip()
    if run.returncode == 0:
        if not os.path.exists(image):
            return "exit 0 without an image", seconds, err
        pixels = read_pfm(image)
        os.remove(image)
        if not all(math.isfinite(p) for p in pixels):
            return "non-finite pixel", seconds, err
        return "ok", seconds, err
    if run.returncode == 2:
        if os.path.exists(image):
            return "exit 2 with output", seconds, err
        if err.count("error:") != 1:
            return "exit 2 without one error line", seconds, err
        return "refused", seconds, err
    return "exit %d" % run.returncode, seconds, err


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("cli")
    ap.add_argument("out")
    ap.add_argument("--methods", default="pathtrace,whitted,progressive,stochastic,matrix")
    ap.add_argument("--formats", default="json,gltf")
    ap.add_argument("--timeout", type=float, default=60.0)
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 2)
    ap.add_argument("--device", default="auto",
                    help="as render --device; cpu skips probing for an OpenGL context each run")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    with open(os.path.join(a.out, "room.obj"), "w") as f:
        f.write(ROOM_OBJ)
    with open(os.path.join(a.out, "panel.obj"), "w") as f:
        f.write(PANEL_OBJ)
    templates = {"json": SCENE, "gltf": quad_gltf()}
    methods = a.methods.split(",")
    # The templates themselves render with every method: a campaign on a refused file tests
    # nothing.
    for fmt in a.formats.split(","):
        scene = os.path.join(a.out, "base." + fmt)
        with open(scene, "w") as f:
            json.dump(templates[fmt], f)
        for method in methods:
            outcome, _, err = run_case(a.cli, scene, method, os.path.join(a.out, "base"),
                                       a.timeout, a.device)
            if outcome != "ok":
                print("the %s template does not render with %s: %s %s" % (fmt, method, outcome,
                                                                          err))
                return 1
    cases = []
    for fmt in a.formats.split(","):
        base = templates[fmt]
        for path in numeric_paths(base):
            for value in HOSTILE:
                cases.append((fmt, path, value))
    outcomes = collections.Counter()
    breaches = []
    slowest = (0.0, "")
    jobs = []
    with concurrent.futures.ThreadPoolExecutor(a.jobs) as pool:
        for n, (fmt, path, value) in enumerate(cases):
            doc = replaced(templates[fmt], path, value)
            scene = os.path.join(a.out, "case%05d.%s" % (n, fmt))
            with open(scene, "w") as f:
                json.dump(doc, f)  # NaN and Infinity as Python writes them
            for method in methods:
                label = "%s %s = %s, %s" % (fmt, "/".join(map(str, path)), json.dumps(value),
                                            method)
                out = os.path.join(a.out, "case%05d-%s" % (n, method))
                jobs.append((label, pool.submit(run_case, a.cli, scene, method, out, a.timeout,
                                                a.device)))
        for label, job in jobs:
            outcome, seconds, err = job.result()
            outcomes[outcome] += 1
            if seconds > slowest[0]:
                slowest = (seconds, label)
            if outcome not in ("ok", "refused"):
                breaches.append("%s: %s (%.1f s) %s" % (label, outcome, seconds, err[-300:]))
    total = sum(outcomes.values())
    print("%d runs (%d values x %d hostile values x %d methods): %s" % (
        total, len(cases) // len(HOSTILE), len(HOSTILE), len(methods),
        ", ".join("%s %d" % kv for kv in sorted(outcomes.items()))))
    print("slowest run: %.1f s (%s)" % slowest)
    for b in breaches:
        print("BREACH " + b)
    return 1 if breaches else 0


if __name__ == "__main__":
    sys.exit(main())
