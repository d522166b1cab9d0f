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

import inspect
import json
import os
from typing import Callable, Optional, Union

import numpy as np

from ._penumbra import Error, InputError, Scene, version
from ._penumbra import _bake, _methods, _options, _read_image, _render, _trace, _write_image
from . import _signatures as _option_docs
from ._progress import callback as _progress_callback
from ._results import BakeResult, RenderResult, png_bytes, read_atlas
from ._scene import (Camera, DirectionalLight, Luminaire, Material, PointLight, SpotLight,
                     save as _save_scene, save_method as _save_method)
from . import _scene

__all__ = [
    "Error",
    "InputError",
    "Scene",
    "Material",
    "PointLight",
    "SpotLight",
    "DirectionalLight",
    "Luminaire",
    "Camera",
    "RenderResult",
    "BakeResult",
    "load",
    "from_arrays",
    "save_scene",
    "methods",
    "render",
    "bake",
    "trace",
    "read_image",
    "write_image",
    "png_bytes",
    "version",
]

__version__ = version()

ProgressCallback = Callable[[str, float], None]

Scene.save = _save_method


def load(name_or_path: Union[str, os.PathLike], camera=None, lights=None, settings=None, *,
         allow_outside_files: bool = False, max_texture_size: int = 8192,
         gltf_scene: Optional[int] = None) -> Scene:
    """A built-in scene ("cornell", "sss", "lpv") or a .json, .obj, .gltf, .glb or .ply file.

    ``camera`` (a :class:`Camera` or the scene format's dict) replaces the file's camera,
    ``lights`` (:class:`PointLight`, :class:`SpotLight`, :class:`DirectionalLight`,
    :class:`Luminaire` or dicts) are added to its lights, and ``settings`` (``{"method":
    {"option": value}}``) to its per-method settings; all are checked as a scene file's are.

    ``allow_outside_files`` lets a glTF or OBJ file read files outside its own folder (refused
    by default), ``max_texture_size`` is the largest side a texture keeps (larger ones are
    reduced, with a warning), ``gltf_scene`` which scene of a glTF file to load."""
    return _scene.load(name_or_path, camera, lights, settings, allow_outside_files,
                       max_texture_size, gltf_scene)


def from_arrays(
    positions,
    indices,
    material_ids=None,
    materials: Optional[list] = None,
    lights: Optional[list] = None,
    camera=None,
    environment=None,
    settings: Optional[dict] = None,
    source: str = "arrays",
) -> Scene:
    """A scene of one mesh from arrays.

    ``positions``: V x 3 (metres); ``indices``: T x 3 vertex indices (counter-clockwise is the
    front); ``material_ids``: T indices into ``materials``. ``materials`` (:class:`Material` or
    dicts), ``lights`` (:class:`PointLight`, :class:`SpotLight`, :class:`DirectionalLight`,
    :class:`Luminaire` or dicts), ``camera`` (:class:`Camera` or a dict), ``environment`` and
    ``settings`` are the JSON scene format's entries (docs/scene-format.md), e.g.
    ``materials=[Material("white", reflectance=[0.8, 0.8, 0.8])]``,
    ``lights=[PointLight(position=[0, 1, 0], intensity=[5, 5, 5])]``,
    ``camera=Camera(position=[0, 0, 3], look_at=[0, 0, 0], fov_deg=40)``.
    ``scene.save("scene.json")`` writes it back out as a scene file.
    """
    return _scene.from_arrays(positions, indices, material_ids, materials, lights, camera,
                              environment, settings, source)


def save_scene(scene: Scene, path: Union[str, os.PathLike]) -> list:
    """The same as ``scene.save(path)``."""
    return _save_scene(scene, path)


save_scene.__doc__ = _save_scene.__doc__


def read_image(path: Union[str, os.PathLike]) -> np.ndarray:
    """An image file (.exr, .hdr, .pfm linear; .png decoded from sRGB) as H x W x 3 float32."""
    return _read_image(os.fspath(path))


def write_image(path: Union[str, os.PathLike], image, tonemap: str = "reinhard",
                exposure: float = 0.0) -> None:
    """Writes H x W x 3 linear values by the extension of ``path``; a .png is tone-mapped with
    ``tonemap`` ("reinhard" or "exposure", as ``--tonemap``) at ``exposure`` stops."""
    _write_image(os.fspath(path), np.asarray(image, dtype=np.float32), tonemap, exposure)


_LOAD_OPTIONS = ("allow_outside_files", "max_texture_size", "gltf_scene")


def _scene_of(scene, options: dict) -> Scene:
    """The scene to run on: a :class:`Scene` as it is, a name or file loaded with the options
    that say how to read it. They stay in ``options``, so the library checks their values as it
    checks every option's (a loaded scene has no more use for them)."""
    if isinstance(scene, Scene):
        return scene
    load_options = {k: options[k] for k in _LOAD_OPTIONS if options.get(k) is not None}
    try:
        return load(scene, **load_options)
    except TypeError as e:
        raise InputError(f"{scene}: {e}") from None


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


def render(scene, method: str = "pathtrace", *, progress=None, quiet: bool = True,
           **options) -> RenderResult:
    """Renders ``scene`` (a :class:`Scene`, a built-in name or a file) with ``method``: pathtrace,
    whitted, photons, matrix, progressive, stochastic, sss or lpv. The other arguments are
    ``penumbra render``'s options, below (``device="gpu"``, ``spp=256``, ``output="out.exr"``,
    ...); one left at None keeps the method's default. Each is checked before any work: an
    option another method owns, a value of the wrong type or out of the method's range raises
    :class:`InputError` naming it.

    ``progress``: None shows a tqdm bar per stage when tqdm is installed and the call runs in a
    terminal or a Jupyter kernel; False shows nothing; a callable is called as ``progress(stage,
    fraction)`` now and then. Log lines go to stderr unless ``quiet``."""
    loaded = _scene_of(scene, options)
    values = [("method", method), ("quiet", quiet)] + _values(options)
    images, stats = _run(_render, loaded, values, progress)
    return RenderResult(
        image=images[-1] if images else None,
        images=images,
        stats=json.loads(stats) if stats else {},
    )


def bake(scene, output: Union[str, os.PathLike] = ".", method: str = "matrix", *, progress=None,
         quiet: bool = True, **options) -> BakeResult:
    """Bakes ``scene``'s radiosity into a lightmap atlas and writes it into the directory
    ``output`` as ``penumbra bake`` does (the glTF, its buffer, the lightmap as EXR and PNG).
    ``method``: matrix, progressive or stochastic; the other arguments are ``penumbra bake``'s
    options, below, checked before any work as :func:`render`'s are, and ``progress`` as
    :func:`render`'s. On Ctrl-C a progressive bake writes its checkpoint first (``resume=``
    continues it). The result holds the lightmap, the atlas UVs and the files written."""
    out = os.fspath(output)
    loaded = _scene_of(scene, options)
    values = [("method", method), ("output", out), ("quiet", quiet)] + _values(options)
    images, stats = _run(_bake, loaded, values, progress)
    stats = json.loads(stats) if stats else {}
    outputs = stats.get("outputs")
    # The paths as the bake wrote them (inside `output`, relative where it is).
    files = [os.fspath(f) for f in outputs] if isinstance(outputs, list) else []
    result = BakeResult(lightmap=images[0] if images else None, stats=stats, output=out,
                        files=files)
    if result.gltf and os.path.exists(result.gltf):
        result.uvs, result.uv_triangles = read_atlas(result.gltf)
    return result


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
    # Checked here as render's options are checked by the library: a wrong type names the
    # argument in an InputError, before any work (the binding would raise a TypeError).
    for name, value in (("occlusion", occlusion), ("quiet", quiet)):
        if not isinstance(value, (bool, np.bool_)):
            raise InputError(f"{name}: must be True or False, not {value!r}")
    whole = {"threads": threads, "t_min": t_min, "t_max": t_max, "r_min": r_min,
             "cache_rays": cache_rays}
    for name, value in whole.items():
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or \
                not 0 <= int(value) <= 0xFFFFFFFF or (name == "threads" and int(value) > 1024):
            bound = "1024" if name == "threads" else "2^32 - 1"
            raise InputError(f"{name}: must be a whole number from 0 to {bound}, not {value!r}")
    if not isinstance(device, str):
        raise InputError(f"device: must be cpu, gpu, hybrid or auto, not {device!r}")
    result = _trace(_scene_of(scene, {}), rays, device, bool(occlusion), int(threads), int(t_min),
                    int(t_max), int(r_min), int(cache_rays), bool(quiet))
    result["stats"] = json.loads(result["stats"])
    return result


def _run(command, scene: Scene, values: list, progress):
    report, close = _progress_callback(progress)
    finished = False
    try:
        result = command(scene, values, report)
        finished = True
        return result
    finally:
        close(finished)


def _with_options(doc: str, command: str) -> str:
    """`doc` and the options of `command`, indented as the docstring's own lines are."""
    section = "Options (the methods that take one, with their defaults, in brackets):\n" + \
        _option_docs.help_section(command)
    return doc + "\n\n" + "\n".join("    " + line for line in section.splitlines())


render.__doc__ = _with_options(render.__doc__, "render")
bake.__doc__ = _with_options(bake.__doc__, "bake")
# Every option a named, typed keyword-only parameter, for help(), inspect and editors; the
# function takes them as **options and the library checks them (a misspelt one included).
_P = inspect.Parameter
render.__signature__ = _option_docs.signature("render", [
    _P("scene", _P.POSITIONAL_OR_KEYWORD),
    _P("method", _P.POSITIONAL_OR_KEYWORD, default="pathtrace", annotation=str),
    _P("progress", _P.KEYWORD_ONLY, default=None),
    _P("quiet", _P.KEYWORD_ONLY, default=True, annotation=bool),
])
bake.__signature__ = _option_docs.signature("bake", [
    _P("scene", _P.POSITIONAL_OR_KEYWORD),
    _P("output", _P.POSITIONAL_OR_KEYWORD, default=".", annotation=str),
    _P("method", _P.POSITIONAL_OR_KEYWORD, default="matrix", annotation=str),
    _P("progress", _P.KEYWORD_ONLY, default=None),
    _P("quiet", _P.KEYWORD_ONLY, default=True, annotation=bool),
])
del _P
