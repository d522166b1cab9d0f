"""Which lightmap texels carry surface, read from a baked glTF (the asset output).

A texel's weight is the share of its square that is surface: inside a lightmapped triangle (by
its lightmap UVs, `PENUMBRA_lightmap.texCoord`) and, for `alphaMode` MASK materials, where the
base colour's alpha (factor times texture, bilinear, REPEAT) reaches `alphaCutoff`. Gutter texels
(the dilation around charts) and the holes of cut-outs weigh 0: their values are copies of their
neighbours', which no fragment shows except through bilinear filtering.

Computed here from the file, independently of the engine's own coverage, on an n x n grid of
points per texel.
"""
import io
import json
import os
import struct

import numpy as np

COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}
DTYPES = {5120: "i1", 5121: "u1", 5122: "i2", 5123: "u2", 5125: "u4", 5126: "f4"}


def _load(path):
    if path.endswith(".glb"):
        data = open(path, "rb").read()
        length = struct.unpack_from("<I", data, 12)[0]
        doc = json.loads(data[20:20 + length])
        binary = data[20 + length + 8:]
        return doc, [binary]
    doc = json.load(open(path))
    base = os.path.dirname(path)
    return doc, [open(os.path.join(base, b["uri"]), "rb").read() for b in doc["buffers"]]


def _accessor(doc, buffers, i):
    a = doc["accessors"][i]
    view = doc["bufferViews"][a["bufferView"]]
    n = COMPONENTS[a["type"]]
    dt = np.dtype(DTYPES[a["componentType"]])
    stride = view.get("byteStride", 0) or n * dt.itemsize
    offset = view.get("byteOffset", 0) + a.get("byteOffset", 0)
    raw = np.frombuffer(buffers[view.get("buffer", 0)], dtype=np.uint8)
    rows = np.lib.stride_tricks.as_strided(raw[offset:], shape=(a["count"], n * dt.itemsize),
                                           strides=(stride, 1))
    out = rows.copy().view(dt).reshape(a["count"], n).astype(np.float64)
    if a.get("normalized"):
        out /= float(np.iinfo(dt).max)
    return out


def _alpha_image(doc, buffers, texture_index):
    from PIL import Image  # Debian's python3-pil
    image = doc["images"][doc["textures"][texture_index]["source"]]
    if "bufferView" in image:
        view = doc["bufferViews"][image["bufferView"]]
        start = view.get("byteOffset", 0)
        data = buffers[view.get("buffer", 0)][start:start + view["byteLength"]]
    else:
        raise ValueError("images by URI are not read here")
    img = Image.open(io.BytesIO(data)).convert("RGBA")
    return np.asarray(img, dtype=np.float64)[..., 3] / 255.0


def _bilinear_repeat(alpha, uv):
    h, w = alpha.shape
    x = uv[:, 0] * w - 0.5
    y = uv[:, 1] * h - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = x - x0, y - y0
    x0 = x0.astype(np.int64)
    y0 = y0.astype(np.int64)

    def at(xx, yy):
        return alpha[np.mod(yy, h), np.mod(xx, w)]
    return ((1 - fx) * (1 - fy) * at(x0, y0) + fx * (1 - fy) * at(x0 + 1, y0) +
            (1 - fx) * fy * at(x0, y0 + 1) + fx * fy * at(x0 + 1, y0 + 1))


def texel_weights(gltf_path, width, height, grid=8):
    """Per texel of a width x height lightmap, the share of it that is surface (0 to 1)."""
    doc, buffers = _load(gltf_path)
    weight = np.zeros((height, width))
    sub = (np.arange(grid) + 0.5) / grid
    for mesh in doc.get("meshes", []):
        for prim in mesh["primitives"]:
            material = doc["materials"][prim.get("material", 0)] if "material" in prim else {}
            ext = material.get("extensions", {}).get("PENUMBRA_lightmap")
            if ext is None:
                continue
            uv = _accessor(doc, buffers, prim["attributes"]["TEXCOORD_%d" % ext["texCoord"]])
            uv = uv * [width, height]
            if "indices" in prim:
                idx = _accessor(doc, buffers, prim["indices"]).astype(np.int64).ravel()
            else:
                idx = np.arange(len(uv))
            mask = None
            if material.get("alphaMode") == "MASK":
                pbr = material.get("pbrMetallicRoughness", {})
                factor = pbr.get("baseColorFactor", [1, 1, 1, 1])[3]
                cutoff = material.get("alphaCutoff", 0.5)
                tex = pbr.get("baseColorTexture")
                if tex is not None:
                    mask = (_alpha_image(doc, buffers, tex["index"]),
                            _accessor(doc, buffers,
                                      prim["attributes"]["TEXCOORD_%d" % tex.get("texCoord", 0)]),
                            factor, cutoff)
                elif factor < cutoff:
                    continue
            for t in range(len(idx) // 3):
                i0, i1, i2 = idx[3 * t:3 * t + 3]
                a, b, c = uv[i0], uv[i1], uv[i2]
                m = np.array([b - a, c - a]).T
                det = np.linalg.det(m)
                if abs(det) < 1e-12:
                    continue
                inv = np.linalg.inv(m)
                lo = np.floor(np.minimum(np.minimum(a, b), c)).astype(int)
                hi = np.ceil(np.maximum(np.maximum(a, b), c)).astype(int)
                for y in range(max(lo[1], 0), min(hi[1], height)):
                    for x in range(max(lo[0], 0), min(hi[0], width)):
                        p = np.stack(np.meshgrid(x + sub, y + sub), -1).reshape(-1, 2)
                        w = (p - a) @ inv.T
                        inside = (w[:, 0] >= 0) & (w[:, 1] >= 0) & (w.sum(1) <= 1)
                        if not inside.any():
                            continue
                        if mask is not None:
                            alpha, tuv, factor, cutoff = mask
                            bary = w[inside]
                            st = (tuv[i0] + bary[:, :1] * (tuv[i1] - tuv[i0]) +
                                  bary[:, 1:] * (tuv[i2] - tuv[i0]))
                            solid = factor * _bilinear_repeat(alpha, st) >= cutoff
                            weight[y, x] += solid.sum() / len(p)
                        else:
                            weight[y, x] += inside.sum() / len(p)
    return np.minimum(weight, 1.0)


def rms_over_surface(got, ref, weights):
    """RMS of got - ref over the texels, each weighted by its share of surface, over the
    weighted mean of ref; and the ratio of the weighted means."""
    w = weights
    mean_ref = float((w * ref).sum() / w.sum())
    rms = float(np.sqrt((w * (got - ref) ** 2).sum() / w.sum()) / mean_ref)
    return rms, float((w * got).sum() / w.sum()) / mean_ref
