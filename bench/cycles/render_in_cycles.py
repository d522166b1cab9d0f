"""Renders a Penumbra JSON scene with Blender's Cycles, the path tracer's peer in
bench/pathtracer_vs_cycles.py. Runs inside Blender (Debian's `blender` package; not a
dependency of the build or the tests):

  blender -b --factory-startup -P bench/cycles/render_in_cycles.py -- SCENE.json OUT.npy \
      --spp N [--width 256] [--height 256] [--threads 2] [--seed 0]

The scene is rebuilt from the JSON file, not imported: the same triangles in the same
coordinates (OBJ and PLY read here, transforms as docs/scene-format.md defines them), Lambertian
materials (Diffuse BSDF, colour = reflectance), front-face emission (an Emission shader whose
strength is zero on back faces) with radiance = colour x strength, point lights of the same
radiant intensity, the same pinhole camera. Cycles settings for a like-for-like comparison with
`penumbra render --method pathtrace`: a box pixel filter one pixel wide, no denoising, no
adaptive sampling, no clamping, no light threshold, bounces unlimited in practice (Russian
roulette ends paths, as in Penumbra), `--threads` threads. Writes the image as float32 H x W x 3
(top row first, linear radiance) to OUT.npy and prints {"seconds": render wall time} as JSON.
"""

import json
import math
import os
import sys
import time

import bpy
import numpy as np
from mathutils import Matrix, Vector

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from external_rays import read_ply  # noqa: E402  (the bench's PLY reader, triangles only)

# One point light of radiant intensity I [W/sr]: Blender's point-light power P [W] with
# P = 4 pi I is what Cycles renders as I (checked by bench/pathtracer_vs_cycles.py --calibrate:
# a point light over a floor against the closed form).
POINT_POWER_PER_INTENSITY = 4.0 * math.pi


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1 :]
    opts = {"spp": 64, "width": 256, "height": 256, "threads": 2, "seed": 0}
    pos = []
    i = 0
    while i < len(argv):
        if argv[i].startswith("--"):
            opts[argv[i][2:]] = int(argv[i + 1])
            i += 2
        else:
            pos.append(argv[i])
            i += 1
    return pos[0], pos[1], opts


def read_obj(path):
    verts, faces = [], []
    with open(path) as f:
        for line in f:
            t = line.split()
            if not t:
                continue
            if t[0] == "v":
                verts.append([float(x) for x in t[1:4]])
            elif t[0] == "f":
                idx = []
                for tok in t[1:]:
                    k = int(tok.split("/")[0])
                    idx.append(k - 1 if k > 0 else len(verts) + k)
                faces += [(idx[0], idx[j], idx[j + 1]) for j in range(1, len(idx) - 1)]
    return np.array(verts, np.float64), faces


def transform_matrix(t):
    if not t:
        return np.eye(4)
    if "matrix" in t:
        return np.array(t["matrix"], np.float64).reshape(4, 4)
    s = t.get("scale", 1.0)
    s = [s, s, s] if isinstance(s, (int, float)) else s
    m = np.diag([s[0], s[1], s[2], 1.0])
    rx, ry, rz = [math.radians(a) for a in t.get("rotate_deg", [0, 0, 0])]

    def rot(axis, a):
        c, sn = math.cos(a), math.sin(a)
        r = np.eye(4)
        i, j = [(1, 2), (2, 0), (0, 1)][axis]
        r[i, i], r[i, j], r[j, i], r[j, j] = c, -sn, sn, c
        return r

    m = rot(2, rz) @ rot(1, ry) @ rot(0, rx) @ m
    tr = np.eye(4)
    tr[:3, 3] = t.get("translate", [0, 0, 0])
    return tr @ m


def material_node_tree(name, m):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    diffuse = nt.nodes.new("ShaderNodeBsdfDiffuse")
    rho = m.get("reflectance", [0.8, 0.8, 0.8])
    diffuse.inputs["Color"].default_value = (rho[0], rho[1], rho[2], 1.0)
    diffuse.inputs["Roughness"].default_value = 0.0
    geometry = nt.nodes.new("ShaderNodeNewGeometry")
    surface = diffuse.outputs["BSDF"]
    if not m.get("two_sided", True):
        black = nt.nodes.new("ShaderNodeBsdfDiffuse")
        black.inputs["Color"].default_value = (0, 0, 0, 1)
        mix = nt.nodes.new("ShaderNodeMixShader")
        nt.links.new(geometry.outputs["Backfacing"], mix.inputs["Fac"])
        nt.links.new(surface, mix.inputs[1])
        nt.links.new(black.outputs["BSDF"], mix.inputs[2])
        surface = mix.outputs["Shader"]
    e = m.get("emission")
    if e and max(e) > 0:
        emission = nt.nodes.new("ShaderNodeEmission")
        emission.inputs["Color"].default_value = (e[0], e[1], e[2], 1.0)
        front = nt.nodes.new("ShaderNodeMath")
        front.operation = "SUBTRACT"
        front.inputs[0].default_value = 1.0
        nt.links.new(geometry.outputs["Backfacing"], front.inputs[1])
        nt.links.new(front.outputs["Value"], emission.inputs["Strength"])
        add = nt.nodes.new("ShaderNodeAddShader")
        nt.links.new(surface, add.inputs[0])
        nt.links.new(emission.outputs["Emission"], add.inputs[1])
        surface = add.outputs["Shader"]
    nt.links.new(surface, out.inputs["Surface"])
    return mat


def load_json_with_comments(path):
    """The scene format allows // and /* */ comments outside strings (docs/scene-format.md)."""
    text, out, i, in_string = open(path).read(), [], 0, False
    while i < len(text):
        c = text[i]
        if in_string:
            out.append(c)
            if c == "\\":
                out.append(text[i + 1])
                i += 1
            elif c == '"':
                in_string = False
        elif c == '"':
            in_string = True
            out.append(c)
        elif text.startswith("//", i):
            i = text.find("\n", i)
            i = len(text) if i < 0 else i
            continue
        elif text.startswith("/*", i):
            i = text.find("*/", i) + 2
            continue
        else:
            out.append(c)
        i += 1
    return json.loads("".join(out))


def build(scene_path):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    data = load_json_with_comments(scene_path)
    base = os.path.dirname(os.path.abspath(scene_path))
    mats = {name: material_node_tree(name, m) for name, m in data.get("materials", {}).items()}
    default = material_node_tree("default", {"reflectance": [0.8, 0.8, 0.8]})
    for k, entry in enumerate(data["meshes"]):
        path = os.path.join(base, entry["file"])
        if path.lower().endswith(".ply"):
            verts, faces = read_ply(path)
            verts, faces = verts.astype(np.float64), [tuple(f) for f in faces.tolist()]
        else:
            verts, faces = read_obj(path)
        m = transform_matrix(entry.get("transform"))
        v = (np.c_[verts, np.ones(len(verts))] @ m.T)[:, :3]
        if np.linalg.det(m[:3, :3]) < 0:
            faces = [(a, c, b) for a, b, c in faces]
        mesh = bpy.data.meshes.new(entry.get("name", "mesh%d" % k))
        mesh.from_pydata(v.tolist(), [], faces)
        mesh.update()
        obj = bpy.data.objects.new(mesh.name, mesh)
        obj.data.materials.append(mats.get(entry.get("material"), default))
        scene.collection.objects.link(obj)
    for k, light in enumerate(data.get("lights", [])):
        if light["type"] != "point":
            sys.exit("only point lights are rebuilt for Cycles")
        intensity = light["intensity"]
        peak = max(intensity)
        ld = bpy.data.lights.new("light%d" % k, type="POINT")
        ld.energy = peak * POINT_POWER_PER_INTENSITY
        ld.color = [c / peak for c in intensity]
        ld.shadow_soft_size = 0.0
        ld.cycles.max_bounces = 1024
        obj = bpy.data.objects.new(ld.name, ld)
        obj.location = light["position"]
        scene.collection.objects.link(obj)
    cam = data["camera"]
    cd = bpy.data.cameras.new("camera")
    cd.sensor_fit = "VERTICAL"
    cd.angle_y = math.radians(cam.get("fov_deg", 39.3))
    cd.clip_start = 1e-4
    cd.clip_end = 1e6
    obj = bpy.data.objects.new("camera", cd)
    eye, at = Vector(cam["position"]), Vector(cam["look_at"])
    up = Vector(cam.get("up", [0, 1, 0]))
    back = (eye - at).normalized()
    right = up.cross(back).normalized()
    true_up = back.cross(right)
    obj.matrix_world = Matrix(
        ((right.x, true_up.x, back.x, eye.x), (right.y, true_up.y, back.y, eye.y),
         (right.z, true_up.z, back.z, eye.z), (0, 0, 0, 1)))
    scene.collection.objects.link(obj)
    scene.camera = obj
    world = bpy.data.worlds.new("world")
    world.use_nodes = True
    env = data.get("environment", [0, 0, 0])
    env = env if isinstance(env, list) else [env] * 3
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (*env, 1.0)
    scene.world = world
    return scene


def main():
    scene_path, out_path, opts = parse_args()
    scene = build(scene_path)
    r = scene.render
    r.engine = "CYCLES"
    r.resolution_x, r.resolution_y, r.resolution_percentage = opts["width"], opts["height"], 100
    r.threads_mode = "FIXED"
    r.threads = opts["threads"]
    r.filter_size = 1.0
    c = scene.cycles
    c.device = "CPU"
    c.samples = opts["spp"]
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.seed = opts["seed"]
    c.pixel_filter_type = "BOX"
    c.filter_width = 1.0
    c.max_bounces = c.diffuse_bounces = 1024
    c.glossy_bounces = c.transmission_bounces = c.volume_bounces = c.transparent_max_bounces = 0
    c.sample_clamp_direct = c.sample_clamp_indirect = 0.0
    c.light_sampling_threshold = 0.0
    c.blur_glossy = 0.0
    c.caustics_reflective = c.caustics_refractive = True
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    r.image_settings.file_format = "OPEN_EXR"
    r.image_settings.color_depth = "32"
    r.image_settings.color_mode = "RGB"
    exr = out_path + ".exr"
    r.filepath = exr
    t0 = time.time()
    bpy.ops.render.render(write_still=True)
    seconds = time.time() - t0
    img = bpy.data.images.load(exr)
    px = np.array(img.pixels[:], np.float32).reshape(opts["height"], opts["width"], 4)
    np.save(out_path, np.ascontiguousarray(px[::-1, :, :3]))
    os.remove(exr)
    print(json.dumps({"seconds": seconds}))


main()
