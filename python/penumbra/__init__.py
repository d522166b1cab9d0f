"""Penumbra: diffuse and subsurface global illumination, from Python.

Every function runs the library's command of the same name (``penumbra render``, ``bake``,
``trace``) with the same options, checks and messages as the command-line tool: keyword
arguments are its options with ``-`` written ``_`` (``spp=64`` is ``--spp 64``, ``no_cache=True``
is ``--no-cache``), passed as typed values and checked by the library's descriptions of the
options (a wrong type, a value out of the method's range or an option another method owns raises
:class:`InputError` naming it, before any work). ``help(penumbra.render)`` lists every option;
:func:`methods` lists the methods. Images come back as NumPy float32 arrays (H x W x 3, linear), statistics as
dicts. The work runs with the GIL released; Ctrl-C stops it and raises KeyboardInterrupt. Bad
input raises :class:`InputError` (a :class:`ValueError`) with the library's message, naming the
file and the place in it. See docs/python.md.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from typing import Callable, Optional, Union

import numpy as np

from ._penumbra import Error, InputError, Scene, version
from ._penumbra import _bake, _methods, _options, _read_image, _render, _trace, _write_image

__all__ = [
    "Error",
    "InputError",
    "Scene",
    "RenderResult",
    "BakeResult",
    "load",
    "from_arrays",
    "methods",
    "render",
    "bake",
    "trace",
    "read_image",
    "write_image",
    "version",
]

__version__ = version()

ProgressCallback = Callable[[str, float], None]


@dataclass
class RenderResult:
    """What :func:`render` gives back."""

    image: np.ndarray  # H x W x 3 float32: the image, or the last frame of a sequence
    images: list  # every frame (one for a still)
    stats: dict  # what ``--stats`` writes


@dataclass
class BakeResult:
    """What :func:`bake` gives back: the lightmap atlas; the files are in ``output``."""

    # H x W x 3 float32 per texel, linear: what the EXR holds (irradiance in W m^-2 for the
    # default gltf="asset" output, outgoing radiance for gltf="emissive")
    lightmap: np.ndarray
    stats: dict
    output: str
    files: list = field(default_factory=list)


def load(name_or_path: Union[str, os.PathLike]) -> Scene:
    """A built-in scene ("cornell", "sss", "lpv") or a .json, .obj, .gltf, .glb or .ply file."""
    return Scene.load(os.fspath(name_or_path))


def from_arrays(
    positions,
    indices,
    material_ids=None,
    materials: Optional[list] = None,
    lights: Optional[list] = None,
    camera: Optional[dict] = None,
    environment=None,
    source: str = "arrays",
) -> Scene:
    """A scene of one mesh from arrays.

    ``positions``: V x 3 (metres); ``indices``: T x 3 vertex indices (counter-clockwise is the
    front); ``material_ids``: T indices into ``materials``. ``materials``, ``lights``, ``camera``
    and ``environment`` are written as in the JSON scene format (docs/scene-format.md), e.g.
    ``materials=[{"name": "white", "reflectance": [0.8, 0.8, 0.8]}]``,
    ``lights=[{"type": "point", "position": [0, 1, 0], "intensity": [5, 5, 5]}]``,
    ``camera={"position": [0, 0, 3], "look_at": [0, 0, 0], "fov_deg": 40}``.
    """
    description = {}
    if materials is not None:
        description["materials"] = list(materials)
    if lights is not None:
        description["lights"] = list(lights)
    if camera is not None:
        description["camera"] = dict(camera)
    if environment is not None:
        description["environment"] = environment
    # The arrays go as they are: the module checks their shapes, the memory of any copy, and that
    # indices are whole numbers (2.7 is refused, not truncated) before converting them.
    ids = None if material_ids is None else np.asarray(material_ids)
    return Scene.from_arrays(
        np.asarray(positions),
        np.asarray(indices),
        ids,
        json.dumps(description, default=_json_value),
        source,
    )


def read_image(path: Union[str, os.PathLike]) -> np.ndarray:
    """An image file (.exr, .hdr, .pfm linear; .png decoded from sRGB) as H x W x 3 float32."""
    return _read_image(os.fspath(path))


def write_image(path: Union[str, os.PathLike], image, tonemap: str = "reinhard",
                exposure: float = 0.0) -> None:
    """Writes H x W x 3 linear values by the extension of ``path``; a .png is tone-mapped with
    ``tonemap`` ("reinhard" or "exposure", as ``--tonemap``) at ``exposure`` stops."""
    _write_image(os.fspath(path), np.asarray(image, dtype=np.float32), tonemap, exposure)


def _json_value(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"{type(value).__name__} is not a JSON value")


def _scene(scene) -> Scene:
    return scene if isinstance(scene, Scene) else load(scene)


def _values(options: dict) -> list:
    """Keyword arguments as the library's typed values: ``None`` leaves an option unset; paths
    become strings, NumPy scalars and arrays Python numbers and lists."""
    values = []
    for key, value in options.items():
        if value is None:
            continue
        if isinstance(value, os.PathLike):
            value = os.fspath(value)
        elif isinstance(value, np.ndarray):
            value = value.tolist()
        elif isinstance(value, np.generic):
            value = value.item()
        elif isinstance(value, tuple):
            value = list(value)
        if isinstance(value, list):
            value = [os.fspath(v) if isinstance(v, os.PathLike) else v for v in value]
        values.append((key, value))
    return values


def methods() -> list:
    """The methods, each a dict: ``name``, ``summary``, ``source`` (the paper), ``bakes``, and
    ``options``: the names of the render options that only some methods take and this one does."""
    own = {}
    for o in _options("render"):
        for method, _, _ in o["methods"]:
            own.setdefault(method, []).append(o["name"].replace("-", "_"))
    return [dict(m, options=own.get(m["name"], [])) for m in _methods()]


def _option_help(command: str) -> str:
    """The options of ``command`` as a docstring section, from the library's descriptions."""
    lines = []
    for o in _options(command):
        kind = o["kind"]
        if o["choices"]:
            kind = " | ".join(repr(c) for c in o["choices"])
        details = [kind]
        if o["unit"]:
            details.append(o["unit"])
        if o["range"]:
            details.append(o["range"])
        taken = ", ".join(m + (f": {d}" if d else "") + (f" in {r}" if r else "")
                          for m, d, r in o["methods"])
        lines.append(f"    {o['name'].replace('-', '_')} ({'; '.join(details)})"
                     + (f" [{taken}]" if taken else ""))
        lines.append(f"        {o['help']}")
    return "\n".join(lines)


def render(
    scene,
    method: str = "pathtrace",
    *,
    progress: Optional[ProgressCallback] = None,
    quiet: bool = True,
    **options,
) -> RenderResult:
    """Renders ``scene`` (a :class:`Scene`, a built-in name or a file) with ``method``: pathtrace,
    whitted, photons, matrix, progressive, stochastic, sss or lpv; the other options are ``penumbra render``'s
    (``device="gpu"``, ``spp=256``, ``output="out.exr"``, ``threads=2``, ...). ``progress(stage,
    fraction)`` is called now and then. Log lines go to stderr unless ``quiet``."""
    values = [("method", method), ("quiet", quiet)] + _values(options)
    images, stats = _render(_scene(scene), values, progress)
    return RenderResult(
        image=images[-1] if images else None,
        images=images,
        stats=json.loads(stats) if stats else {},
    )


def bake(
    scene,
    output: Union[str, os.PathLike] = ".",
    method: str = "matrix",
    *,
    progress: Optional[ProgressCallback] = None,
    quiet: bool = True,
    **options,
) -> BakeResult:
    """Bakes ``scene``'s radiosity into a lightmap atlas and writes it into the directory
    ``output`` as ``penumbra bake`` does (the glTF, its buffer, the lightmap as EXR and PNG).
    ``method``: matrix, progressive or stochastic; the other options are ``penumbra bake``'s. On
    Ctrl-C a progressive bake writes its checkpoint first (``resume=`` continues it)."""
    out = os.fspath(output)
    values = [("method", method), ("output", out), ("quiet", quiet)] + _values(options)
    images, stats = _bake(_scene(scene), values, progress)
    stats = json.loads(stats) if stats else {}
    files = [os.path.join(out, f) for f in stats.get("outputs", [])] if isinstance(
        stats.get("outputs"), list) else []
    return BakeResult(lightmap=images[0] if images else None, stats=stats, output=out, files=files)


def trace(
    scene,
    rays,
    device: str = "auto",
    occlusion: bool = False,
    threads: int = 0,
    t_min: int = 64,
    t_max: int = 1024,
    r_min: int = 256,
    cache_rays: int = 0,
    quiet: bool = True,
) -> dict:
    """Traces ``rays`` (N x 8 float32: ox oy oz tmin dx dy dz tmax, the ray file's layout, read in
    place when C-contiguous float32) against ``scene``'s triangles, numbered as
    :meth:`Scene.flat_indices` lists them, on ``device`` (cpu, gpu, hybrid or auto, as ``penumbra
    trace --device``; ``t_min``, ``t_max``, ``r_min``, ``cache_rays`` tune hybrid; the log line
    goes to stderr unless ``quiet``). Returns ``{"triangle", "t", "u", "v", "stats"}`` (triangle -1
    and t infinite for a miss) or, with ``occlusion``, ``{"occluded", "stats"}``."""
    result = _trace(_scene(scene), rays, device, occlusion, threads, t_min, t_max, r_min,
                    cache_rays, quiet)
    result["stats"] = json.loads(result["stats"])
    return result


render.__doc__ += "\n\nOptions (the methods that take one, with their defaults, in brackets):\n" + \
    _option_help("render")
bake.__doc__ += "\n\nOptions (the methods that take one, with their defaults, in brackets):\n" + \
    _option_help("bake")
