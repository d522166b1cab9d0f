"""What render() and bake() give back: NumPy arrays, dicts and paths, shown as pictures in
Jupyter (_repr_png_, _repr_html_: the image tone-mapped by the library's own PNG writer)."""

from __future__ import annotations

import base64
import html
import json
import os
import tempfile
from dataclasses import dataclass, field
from typing import List, Optional

import numpy as np

from ._penumbra import _write_image


def png_bytes(image, tonemap: str = "reinhard", exposure: float = 0.0) -> bytes:
    """H x W x 3 linear values as a PNG file's bytes, tone-mapped as ``penumbra render -o
    x.png --tonemap TONEMAP --exposure EXPOSURE`` writes them."""
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "image.png")
        _write_image(path, np.asarray(image, dtype=np.float32), tonemap, float(exposure))
        with open(path, "rb") as f:
            return f.read()


def _html(png: bytes, caption: str) -> str:
    data = base64.b64encode(png).decode("ascii")
    return (f'<figure style="margin:0"><img src="data:image/png;base64,{data}"/>'
            f"<figcaption>{html.escape(caption)}</figcaption></figure>")


class _Shown:
    """Jupyter's view of a result: its picture as PNG and as HTML with a caption. IPython asks
    for the mime bundle first, so the picture is tone-mapped and encoded once per display;
    _repr_png_ and _repr_html_ serve other front ends."""

    def _picture(self) -> Optional[np.ndarray]:
        raise NotImplementedError

    def _caption(self) -> str:
        raise NotImplementedError

    def _repr_png_(self):
        picture = self._picture()
        return None if picture is None else png_bytes(picture)

    def _repr_html_(self):
        png = self._repr_png_()
        return None if png is None else _html(png, self._caption())

    def _repr_mimebundle_(self, include=None, exclude=None):
        png = self._repr_png_()
        if png is None:
            return {"text/plain": repr(self)}
        return {"image/png": png, "text/html": _html(png, self._caption()),
                "text/plain": repr(self)}


@dataclass(repr=False)
class RenderResult(_Shown):
    """What :func:`render` gives back."""

    image: Optional[np.ndarray]  # H x W x 3 float32, linear: the image, or a sequence's last frame
    images: list  # every frame (one for a still)
    stats: dict  # what ``--stats`` writes

    def __repr__(self) -> str:
        s = self.stats
        size = "no image" if self.image is None else f"{self.image.shape[1]} x {self.image.shape[0]}"
        frames = f", {len(self.images)} frames" if len(self.images) > 1 else ""
        seconds = f", {s['seconds']:.2f} s" if "seconds" in s else ""
        return f"<penumbra.RenderResult {s.get('method', '')}: {size}{frames}{seconds}>"

    def png(self, tonemap: str = "reinhard", exposure: float = 0.0) -> bytes:
        """The image as PNG bytes, tone-mapped as the CLI's PNG output."""
        return png_bytes(self.image, tonemap, exposure)

    def _picture(self):
        return self.image

    def _caption(self) -> str:
        s = self.stats
        parts = [str(s.get("method", "render")), f"{self.image.shape[1]} x {self.image.shape[0]}"]
        if "seconds" in s:
            parts.append(f"{s['seconds']:.2f} s")
        return ", ".join(parts)


@dataclass(repr=False)
class BakeResult(_Shown):
    """What :func:`bake` gives back: the lightmap atlas, its UVs, and the files in ``output``."""

    # H x W x 3 float32 per texel, linear: what the EXR holds (irradiance in W m^-2 for the
    # default gltf="asset" output, outgoing radiance for gltf="emissive")
    lightmap: Optional[np.ndarray]
    stats: dict
    output: str
    files: List[str] = field(default_factory=list)
    # The atlas as the baked glTF holds it: every lightmapped primitive's lightmap UVs (the UV set
    # its material's PENUMBRA_lightmap names; in [0, 1] with v down the image, glTF's
    # convention) one after the other, and their triangles as indices into `uvs`. None when no
    # glTF was written (dry_run).
    uvs: Optional[np.ndarray] = None
    uv_triangles: Optional[np.ndarray] = None

    def __repr__(self) -> str:
        size = ("no lightmap" if self.lightmap is None else
                f"lightmap {self.lightmap.shape[1]} x {self.lightmap.shape[0]}")
        return (f"<penumbra.BakeResult {self.stats.get('method', '')}: {size}, "
                f"{len(self.files)} files in {self.output!r}>")

    @property
    def gltf(self) -> Optional[str]:
        """The baked glTF's path."""
        return next((f for f in self.files if f.endswith((".gltf", ".glb"))), None)

    def _picture(self):
        return self.lightmap

    def _caption(self) -> str:
        h, w = self.lightmap.shape[:2]
        return f"{self.stats.get('method', 'bake')} lightmap, {w} x {h} texels, in {self.output}"


_COMPONENTS = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32,
               5126: np.float32}
_WIDTHS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}


def _accessor(gltf: dict, buffers: list, index: int) -> np.ndarray:
    a = gltf["accessors"][index]
    view = gltf["bufferViews"][a["bufferView"]]
    dtype = np.dtype(_COMPONENTS[a["componentType"]]).newbyteorder("<")
    width = _WIDTHS[a["type"]]
    data = buffers[view["buffer"]]
    start = view.get("byteOffset", 0) + a.get("byteOffset", 0)
    stride = view.get("byteStride", 0) or dtype.itemsize * width
    rows = np.ndarray((a["count"], width), dtype=dtype, buffer=data, offset=start,
                      strides=(stride, dtype.itemsize))
    return np.array(rows)


def _load_gltf(path: str):
    """A .gltf (external or data: buffers) or .glb as (its JSON, its buffers' bytes)."""
    with open(path, "rb") as f:
        raw = f.read()
    glb_bin = None
    if raw[:4] == b"glTF":  # GLB: a 12-byte header, then JSON and BIN chunks
        length = int.from_bytes(raw[12:16], "little")
        gltf = json.loads(raw[20:20 + length].decode("utf-8"))
        rest = 20 + length
        if rest + 8 <= len(raw):
            size = int.from_bytes(raw[rest:rest + 4], "little")
            glb_bin = raw[rest + 8:rest + 8 + size]
    else:
        gltf = json.loads(raw.decode("utf-8"))
    buffers = []
    for b in gltf.get("buffers", []):
        uri = b.get("uri")
        if uri is None:
            buffers.append(glb_bin)
        elif uri.startswith("data:"):
            buffers.append(base64.b64decode(uri.split(",", 1)[1]))
        else:
            with open(os.path.join(os.path.dirname(path), uri), "rb") as f:
                buffers.append(f.read())
    return gltf, buffers


def read_atlas(gltf_path: str):
    """The lightmap UVs and triangles of every lightmapped primitive of a .gltf or .glb written
    by ``penumbra bake``, concatenated: (uvs N x 2 float32, triangles T x 3 uint32). A
    primitive's lightmap UV set is the one its material's PENUMBRA_lightmap extension names
    (docs/web-viewer.md); primitives without it are not in the atlas."""
    gltf, buffers = _load_gltf(gltf_path)
    materials = gltf.get("materials", [])
    uvs, triangles, base = [], [], 0
    for mesh in gltf.get("meshes", []):
        for p in mesh.get("primitives", []):
            material = materials[p["material"]] if "material" in p else {}
            lightmap = material.get("extensions", {}).get("PENUMBRA_lightmap")
            if lightmap is None:
                continue
            key = f"TEXCOORD_{lightmap.get('texCoord', 0)}"
            attributes = p.get("attributes", {})
            if key not in attributes:
                continue
            uv = _accessor(gltf, buffers, attributes[key]).astype(np.float32)
            if "indices" in p:
                tri = _accessor(gltf, buffers, p["indices"]).reshape(-1, 3).astype(np.uint32)
            else:
                tri = np.arange(len(uv), dtype=np.uint32).reshape(-1, 3)
            uvs.append(uv)
            triangles.append(tri + np.uint32(base))
            base += len(uv)
    if not uvs:
        return None, None
    return np.concatenate(uvs), np.concatenate(triangles)
