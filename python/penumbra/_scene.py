"""Scenes from Python: files, arrays, and materials, lights and cameras as Python objects, each
the scene format's entry of the same name (docs/scene-format.md), checked by the library as a
scene file's are. A scene made from arrays can be written back out as a JSON scene file with its
meshes (Scene.save)."""

from __future__ import annotations

import json
import os
import re
import tempfile
from dataclasses import asdict, dataclass, fields
from typing import Optional, Sequence, Union

import numpy as np

from ._penumbra import InputError, Scene

Vec3 = Sequence[float]


class _Entry:
    """A scene-format entry: its dict leaves out the fields left at None (the format's default)."""

    _type: Optional[str] = None

    def to_dict(self) -> dict:
        d = {} if self._type is None else {"type": self._type}
        for f in fields(self):
            value = getattr(self, f.name)
            if value is not None:
                d[f.name] = _json_value(value)
        return d


@dataclass
class Material(_Entry):
    """A material (scene format, "Materials"): Lambertian ``reflectance`` in [0, 1], front-face
    ``emission`` in W m^-2 sr^-1; ``type`` "mirror" or "glass" with ``specular`` and ``ior``;
    ``two_sided`` False for a black back face; ``subsurface`` a preset name or a dict."""

    name: Optional[str] = None
    reflectance: Optional[Vec3] = None
    emission: Optional[Vec3] = None
    type: Optional[str] = None
    specular: Optional[Vec3] = None
    ior: Optional[float] = None
    two_sided: Optional[bool] = None
    subsurface: Optional[Union[str, dict]] = None
    normal_map: Optional[str] = None
    normal_scale: Optional[float] = None


@dataclass
class PointLight(_Entry):
    """A point light: ``intensity`` in W sr^-1 at ``position`` (metres)."""

    position: Vec3
    intensity: Vec3
    _type = "point"


@dataclass
class SpotLight(_Entry):
    """A spot light: ``intensity`` on the axis (W sr^-1), pointing along ``direction``, with the
    glTF fall-off between the half-angles ``inner_angle_deg`` and ``outer_angle_deg``."""

    position: Vec3
    direction: Vec3
    intensity: Vec3
    inner_angle_deg: Optional[float] = None
    outer_angle_deg: Optional[float] = None
    _type = "spot"


@dataclass
class DirectionalLight(_Entry):
    """A distant light travelling along ``direction``: ``irradiance`` in W m^-2 on a surface
    facing it."""

    direction: Vec3
    irradiance: Vec3
    _type = "directional"


@dataclass
class Luminaire(_Entry):
    """A luminaire from a photometric file (EULUMDAT .ldt or IES .ies) at ``position``, aimed
    along ``aim`` (its nadir); the other fields as the scene format's ``luminaire``."""

    file: str
    position: Vec3
    aim: Optional[Vec3] = None
    rotation_deg: Optional[float] = None
    dimming: Optional[float] = None
    flux_lm: Optional[float] = None
    lamps: Optional[float] = None
    colour: Optional[Vec3] = None
    tilt_deg: Optional[float] = None
    array: Optional[dict] = None
    _type = "luminaire"

    def to_dict(self) -> dict:
        d = super().to_dict()
        d["file"] = os.path.abspath(os.fspath(self.file))
        return d


@dataclass
class Camera(_Entry):
    """A pinhole camera at ``position`` looking at ``look_at``; ``fov_deg`` the vertical field of
    view."""

    position: Vec3
    look_at: Vec3
    up: Optional[Vec3] = None
    fov_deg: Optional[float] = None


def _json_value(value):
    if isinstance(value, _Entry):
        return value.to_dict()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (list, tuple)):
        return [_json_value(v) for v in value]
    if isinstance(value, dict):
        return {k: _json_value(v) for k, v in value.items()}
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    return value


def _entries(values, what: str) -> list:
    if isinstance(values, (dict, _Entry)):
        raise InputError(f"{what}: must be a list")
    return [_json_value(v) for v in values]


def describe(materials=None, lights=None, camera=None, environment=None, settings=None) -> dict:
    """The scene-format description of the given parts (None leaves a part out)."""
    d = {}
    if materials is not None:
        d["materials"] = _entries(materials, "materials")
    if lights is not None:
        d["lights"] = _entries(lights, "lights")
    if camera is not None:
        d["camera"] = _json_value(camera)
    if environment is not None:
        d["environment"] = _json_value(environment)
    if settings is not None:
        d["settings"] = _json_value(settings)
    return d


def from_arrays(positions, indices, material_ids=None, materials=None, lights=None,
                camera=None, environment=None, settings=None, source: str = "arrays") -> Scene:
    description = describe(materials, lights, camera, environment, settings)
    # The arrays go as they are: the module checks their shapes, the memory of any copy, and that
    # indices are whole numbers (2.7 is refused, not truncated) before converting them.
    ids = None if material_ids is None else np.asarray(material_ids)
    scene = Scene.from_arrays(np.asarray(positions), np.asarray(indices), ids,
                              json.dumps(description), source)
    # What Scene.save writes back: the description and the material ids (a copy, 4 bytes per
    # triangle); the positions and triangles are read back from the scene when it is saved.
    scene._parts = {"material_ids": None if ids is None else np.array(ids, dtype=np.uint32),
                    "description": description}
    return scene


def _strip_comments(text: str) -> str:
    """JSON with // and /* */ comments (which scene files may have) as plain JSON."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            out.append(text[i:j + 1])
            i = j + 1
        elif text.startswith("//", i):
            while i < n and text[i] != "\n":
                i += 1
        elif text.startswith("/*", i):
            end = n if text.find("*/", i + 2) < 0 else text.find("*/", i + 2) + 2
            out.append("\n" * text.count("\n", i, end))  # messages keep the file's line numbers
            i = end
        else:
            out.append(c)
            i += 1
    return "".join(out)


_MESH_FILES = (".obj", ".gltf", ".glb", ".ply")


def load(name_or_path, camera=None, lights=None, settings=None, allow_outside_files=False,
         max_texture_size=8192, gltf_scene=None) -> Scene:
    path = os.fspath(name_or_path)
    if camera is None and lights is None and settings is None:
        scene = Scene.load(path, bool(allow_outside_files), int(max_texture_size),
                           -1 if gltf_scene is None else int(gltf_scene))
        scene._parts = None
        return scene
    # A file with parts added: its description with them, parsed by the library as the file
    # would be (paths resolve against the file's folder; messages name the file).
    extension = os.path.splitext(path)[1].lower()
    if extension == ".json":
        try:
            with open(path, encoding="utf-8") as f:
                description = json.loads(_strip_comments(f.read()))
        except OSError as e:
            raise InputError(f"{path}: cannot read: {e.strerror}") from None
        except ValueError as e:
            raise InputError(f"{path}: {e}") from None
        if not isinstance(description, dict):
            raise InputError(f"{path}: a scene file is one JSON object")
    elif extension in _MESH_FILES:
        description = {"meshes": [{"file": os.path.basename(path)}]}
    else:
        raise InputError(f"{path}: camera=, lights= and settings= take a scene file (.json) or a "
                         "mesh file (.obj, .gltf, .glb, .ply), not a built-in scene")
    extra = describe(lights=lights, camera=camera, settings=settings)
    if "camera" in extra:
        description["camera"] = extra["camera"]
    if "lights" in extra:
        description["lights"] = list(description.get("lights", [])) + extra["lights"]
    if "settings" in extra:
        merged = dict(description.get("settings", {}))
        for method, values in extra["settings"].items():
            merged[method] = {**merged.get(method, {}), **values}
        description["settings"] = merged
    empty = np.zeros((0, 3), dtype=np.float32)
    scene = Scene.from_arrays(empty, np.zeros((0, 3), dtype=np.uint32), None,
                              json.dumps(description), path)
    scene._parts = None
    return scene


def _ply_bytes(positions: np.ndarray, triangles: np.ndarray) -> bytes:
    header = ("ply\nformat binary_little_endian 1.0\ncomment written by penumbra (Python)\n"
              f"element vertex {len(positions)}\nproperty float x\nproperty float y\n"
              f"property float z\nelement face {len(triangles)}\n"
              "property list uchar uint vertex_indices\nend_header\n")
    faces = np.zeros(len(triangles), dtype=[("n", "u1"), ("v", "<u4", (3,))])
    faces["n"] = 3
    faces["v"] = triangles
    return (header.encode("ascii") + np.ascontiguousarray(positions, dtype="<f4").tobytes() +
            faces.tobytes())


def save(scene: Scene, path) -> list:
    """Writes a scene made by :func:`from_arrays` as a JSON scene file at ``path`` with its mesh
    beside it (PLY, one file per run of triangles with the same material, so triangles keep their
    numbering): ``penumbra render path`` then renders the same scene. Returns the files written."""
    parts = getattr(scene, "_parts", None)
    if not parts:
        raise InputError(f"{scene.source}: only a scene made from arrays is written back out "
                         "(a loaded scene's file is its description)")
    path = os.fspath(path)
    if not path.endswith(".json"):
        raise InputError(f"{path}: a scene file ends in .json")
    folder = os.path.dirname(path)
    stem = os.path.splitext(os.path.basename(path))[0]
    positions, indices = scene.flat_positions(), scene.flat_indices()
    ids = parts["material_ids"]
    if ids is None:
        ids = np.zeros(len(indices), dtype=np.uint32)
    description = json.loads(json.dumps(parts["description"]))
    materials = description.get("materials") or [{"name": "default"}]
    names = []
    for i, m in enumerate(materials):
        names.append(m.get("name") or f"material {i}")
    description["materials"] = {n: {k: v for k, v in m.items() if k != "name"}
                                for n, m in zip(names, materials)}
    if len(set(names)) != len(names):
        raise InputError(f"{path}: materials: names must differ to be written as a scene file")
    # Runs of consecutive triangles with one material, each its own mesh file.
    starts = np.flatnonzero(np.diff(ids.astype(np.int64), prepend=-1))
    ends = np.append(starts[1:], len(ids))
    meshes, contents = [], []
    for k, (a, b) in enumerate(zip(starts, ends)):
        used, local = np.unique(indices[a:b], return_inverse=True)
        mesh_name = f"{stem}_mesh{k}.ply" if len(starts) > 1 else f"{stem}_mesh.ply"
        contents.append((os.path.join(folder, mesh_name),
                         _ply_bytes(positions[used], local.reshape(-1, 3))))
        meshes.append({"file": mesh_name, "material": names[int(ids[a])]})
    description["meshes"] = meshes
    text = json.dumps(description, indent=2)
    # Arrays of numbers on one line each, as the format's examples write them.
    text = re.sub(r"\[\s+([^\[\]{}\"]*?)\s+\]",
                  lambda m: "[" + ", ".join(v.strip() for v in m.group(1).split(",")) + "]", text)
    contents.append((path, (text + "\n").encode("utf-8")))
    _write_all(contents)
    return [p for p, _ in contents]


def _write_all(contents: list) -> None:
    """Writes every (path, bytes) or none: each to a temporary file beside it first, and only
    when all are written are they renamed into place (what the library's writers promise: no
    partial output)."""
    temporary = []
    try:
        for target, data in contents:
            if os.path.exists(target) and not os.path.isfile(target):
                raise InputError(f"{target}: exists and is not a regular file")
            handle, name = tempfile.mkstemp(dir=os.path.dirname(target) or ".",
                                            prefix=".penumbra-")
            temporary.append(name)
            with os.fdopen(handle, "wb") as f:
                f.write(data)
        for (target, _), name in zip(contents, temporary):
            os.chmod(name, 0o644)
            os.replace(name, target)
        temporary = []
    except OSError as e:
        raise InputError(f"{e.filename or contents[0][0]}: cannot write: {e.strerror}") from None
    finally:
        for name in temporary:
            if os.path.exists(name):
                os.remove(name)


def save_method(self, path) -> list:
    return save(self, path)


save_method.__doc__ = save.__doc__
