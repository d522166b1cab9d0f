"""Penumbra as Python users meet it: typed keyword arguments from the library's descriptions,
checked for every method before any work; results that show in Jupyter; progress bars; scenes
from Python objects written back out as scene files (run by `make test`)."""

import base64
import inspect
import io
import json
import os
import sys
import typing

import numpy as np
import pytest

import penumbra
from penumbra import _signatures
from penumbra._penumbra import _options


@pytest.fixture(scope="module")
def cornell():
    return penumbra.load("cornell")


# --- options --------------------------------------------------------------------------------


def test_every_option_is_a_named_typed_parameter():
    for command, function in (("render", penumbra.render), ("bake", penumbra.bake)):
        params = inspect.signature(function).parameters
        for o in _options(command):
            name = o["name"].replace("-", "_")
            assert name in params, f"{command}: {name}"
            if name not in ("method", "output", "quiet"):
                assert params[name].kind == inspect.Parameter.KEYWORD_ONLY, name
    params = inspect.signature(penumbra.render).parameters
    assert params["spp"].annotation == typing.Optional[int]
    assert params["exposure"].annotation == typing.Optional[float]
    assert params["boundary"].annotation == typing.Optional[typing.List[float]]
    assert params["adaptive"].annotation == typing.Optional[bool]
    assert params["method"].default == "pathtrace"
    # help() shows the signature and each option's type, range, per-method defaults and help.
    out = io.StringIO()
    sys.stdout, saved = out, sys.stdout
    try:
        help(penumbra.render)
    finally:
        sys.stdout = saved
    text = out.getvalue()
    assert "spp: Optional[int] = None" in text
    assert "spp (int; [1, 4096]) [pathtrace: 64 in [1, 1048576]" in text
    assert "samples (camera rays, stratified within the pixel) per pixel" in text


def _valid(o):
    kind = o["kind"]
    return {"flag": True, "int": 1, "unsigned": 1, "real": 0.5, "reals": [0.5], "text": "x.exr",
            "choice": (o["choices"] or ["x"])[0]}[kind]


def _wrong_types(o):
    kind = o["kind"]
    return {"flag": ["yes", 2.5], "int": ["1", 1.5], "unsigned": ["1", 2.5], "real": ["0.5"],
            "reals": ["0.5", 0.5j], "text": [3], "choice": [3, "no-such-choice"]}[kind]


def _out_of_range(kind, text):
    r = _signatures.parse_range(text)
    if r is None:
        return []
    lo, lo_closed, hi, hi_closed = r
    whole = kind in ("int", "unsigned")
    values = []
    for v, closed, step in ((lo, lo_closed, -1), (hi, hi_closed, 1)):
        if whole:
            values.append(int(v) + step if closed else int(v))
        else:
            values.append(v + step * max(1.0, abs(v)) if closed else v)
    if kind == "reals":
        values = [[v] for v in values]
    return values


@pytest.mark.parametrize("command", ["render", "bake"])
def test_every_method_refuses_wrong_options_before_any_work(cornell, command, tmp_path):
    """For every method in the registry and every option of the command: an option another
    method owns, a value of the wrong type and a value out of the method's range each raise
    InputError naming the option, and the work never starts (no progress is reported)."""
    function = penumbra.render if command == "render" else penumbra.bake
    methods = [m for m in penumbra.methods() if command == "render" or m["bakes"]]
    assert len(methods) >= (8 if command == "render" else 4)
    checked = 0
    for m in methods:
        for o in _options(command):
            name = o["name"].replace("-", "_")
            if name in ("method", "quiet", "output" if command == "bake" else "-"):
                continue
            uses = {u[0]: u for u in o["methods"]}
            cases = []
            if uses and m["name"] not in uses:
                cases.append(("owned by another method", _valid(o)))
            else:
                cases += [("wrong type", v) for v in _wrong_types(o)]
                own_range = uses[m["name"]][2] if m["name"] in uses else ""
                cases += [("out of range", v)
                          for v in _out_of_range(o["kind"], own_range or o["range"])]
            for what, value in cases:
                progress = []
                args = {name: value}
                if command == "bake":
                    args["output"] = tmp_path / "never"
                with pytest.raises(penumbra.InputError) as raised:
                    function(cornell, method=m["name"], progress=lambda s, f: progress.append(s),
                             **args)
                message = str(raised.value)
                assert o["name"] in message or name in message, \
                    f"{m['name']} {name}={value!r} ({what}): {message}"
                assert not progress, f"{m['name']} {name}={value!r} ({what}) started work"
                checked += 1
    assert checked > (500 if command == "render" else 150)
    assert not (tmp_path / "never").exists()


def test_trace_names_a_wrong_argument_before_any_work():
    rays = np.zeros((4, 8), dtype=np.float32)
    rays[:, 6], rays[:, 7] = 1.0, np.inf
    for kwargs, name in (({"t_min": -1}, "t_min"), ({"t_max": "3"}, "t_max"),
                         ({"cache_rays": 1.5}, "cache_rays"), ({"r_min": True}, "r_min"),
                         ({"threads": 10**6}, "threads"), ({"occlusion": "yes"}, "occlusion"),
                         ({"quiet": 1}, "quiet"), ({"device": 3}, "device"),
                         ({"device": "foo"}, "device"), ({"t_min": 2000, "t_max": 10}, "t-min")):
        with pytest.raises(penumbra.InputError, match=name):
            penumbra.trace("cornell", rays, **kwargs)
    hits = penumbra.trace("cornell", rays, t_min=np.uint32(64), threads=np.int64(1))
    assert hits["triangle"].shape == (4,)


def test_methods_list_each_methods_options():
    listed = {m["name"]: m for m in penumbra.methods()}
    for o in _options("render"):
        for method, _, _ in o["methods"]:
            assert o["name"].replace("-", "_") in listed[method]["options"]


# --- results --------------------------------------------------------------------------------


def test_a_render_shows_in_jupyter_as_the_cli_png(cornell, tmp_path):
    result = penumbra.render(cornell, spp=4, width=24, height=16, progress=False)
    png = result._repr_png_()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    penumbra.write_image(tmp_path / "written.png", result.image)
    assert png == (tmp_path / "written.png").read_bytes()
    decoded = penumbra.read_image(tmp_path / "written.png")
    assert decoded.shape == (16, 24, 3)
    assert repr(result).startswith("<penumbra.RenderResult pathtrace: 24 x 16, ")
    html = result._repr_html_()
    assert "data:image/png;base64," in html and "pathtrace, 24 x 16" in html
    # Jupyter asks for the mime bundle: the picture is encoded once, for both PNG and HTML.
    from penumbra import _results
    encoded = []
    original = _results.png_bytes
    _results.png_bytes = lambda *a, **k: encoded.append(1) or original(*a, **k)
    try:
        bundle = result._repr_mimebundle_()
    finally:
        _results.png_bytes = original
    assert len(encoded) == 1
    assert bundle["image/png"] == png and base64.b64encode(png).decode() in bundle["text/html"]
    # Exposure goes to the library's tone mapping: +1 stop is brighter.
    brighter = penumbra.png_bytes(result.image, "exposure", 1.0)
    (tmp_path / "b.png").write_bytes(brighter)
    penumbra.write_image(tmp_path / "d.png", result.image, "exposure", 0.0)
    assert penumbra.read_image(tmp_path / "b.png").mean() > penumbra.read_image(
        tmp_path / "d.png").mean()


def test_a_bake_gives_its_atlas_uvs_and_they_land_on_lit_texels(tmp_path):
    result = penumbra.bake("cornell", tmp_path / "baked", elements=300, lightmap_size=128,
                           progress=False)
    assert result.gltf == str(tmp_path / "baked" / "cornell.gltf")
    assert all(os.path.exists(f) for f in result.files)
    uv, tri = result.uvs, result.uv_triangles
    assert uv.shape[1] == 2 and tri.shape[1] == 3 and len(tri) == 36
    assert uv.min() >= 0.0 and uv.max() <= 1.0 and tri.max() < len(uv)
    # Every triangle's centroid falls on a texel of the lightmap that holds light, but for the
    # boxes' bottoms, which rest on the floor and receive none; the texels between charts hold
    # none either: the UVs are the atlas's (v down the image, as glTF reads it).
    h, w = result.lightmap.shape[:2]
    luminance = result.lightmap.sum(axis=2)
    centroids = uv[tri].mean(axis=1)
    x = np.clip((centroids[:, 0] * w).astype(int), 0, w - 1)
    y = np.clip((centroids[:, 1] * h).astype(int), 0, h - 1)
    scene = penumbra.load("cornell")
    corners = scene.flat_positions()[scene.flat_indices()]
    normal_y = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])[:, 1]
    on_the_floor = (corners[:, :, 1].max(axis=1) < 1e-3) & (normal_y < 0)
    assert on_the_floor.sum() == 4  # two boxes, two triangles each
    np.testing.assert_array_equal(luminance[y, x] > 0, ~on_the_floor)
    assert (luminance == 0).mean() > 0.05
    assert result._repr_png_()[:4] == b"\x89PNG"
    assert repr(result).startswith("<penumbra.BakeResult matrix: lightmap 128 x 128, 4 files")


def test_the_atlas_of_a_blender_room_is_read_from_the_uv_set_the_bake_names(tmp_path):
    """The textured room's painting already uses TEXCOORD_1 for its own texture: its lightmap
    UVs go to TEXCOORD_2, as its material's PENUMBRA_lightmap says."""
    source = os.environ.get("PENUMBRA_SOURCE_DIR",
                            os.path.join(os.path.dirname(__file__), "..", ".."))
    room = os.path.join(source, "scenes", "textured_room", "room.glb")
    result = penumbra.bake(room, tmp_path / "baked", elements=800, progress=False)
    gltf = json.loads(open(result.gltf).read())
    sets = {m["name"]: m["extensions"]["PENUMBRA_lightmap"]["texCoord"] for m in gltf["materials"]}
    assert sets["Painting"] == 2 and sets["Floor"] == 1
    assert len(result.uv_triangles) == penumbra.load(room).triangle_count
    h, w = result.lightmap.shape[:2]
    corners = result.uvs[result.uv_triangles]
    # Every triangle lies inside the atlas and its centroid's texel holds light (the room has no
    # surface in the dark); none spans the atlas, as the painting's own UVs would.
    assert corners.min() >= 0 and corners.max() <= 1
    assert (np.ptp(corners, axis=1).max(axis=1) < 0.6).all()
    centroids = corners.mean(axis=1)
    x = np.clip((centroids[:, 0] * w).astype(int), 0, w - 1)
    y = np.clip((centroids[:, 1] * h).astype(int), 0, h - 1)
    assert (result.lightmap.sum(axis=2)[y, x] > 0).all()


# --- progress -------------------------------------------------------------------------------


def test_tqdm_shows_each_stage_when_asked(cornell, capsys):
    pytest.importorskip("tqdm")
    penumbra.render(cornell, "progressive", elements=300, width=16, height=16, progress=True)
    err = capsys.readouterr().err
    assert "shooting" in err and "100%" in err
    # A solve that converges early still ends its bar at 100%.
    penumbra.render(cornell, "matrix", elements=300, width=16, height=16, progress=True)
    err = capsys.readouterr().err
    assert any(line.startswith("solving: 100%") for line in err.replace("\r", "\n").splitlines())


def test_without_tqdm_progress_is_quiet(cornell, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "tqdm", None)  # import tqdm raises ImportError
    result = penumbra.render(cornell, spp=2, width=8, height=8, progress=True)
    assert result.image.shape == (8, 8, 3)
    assert capsys.readouterr().err == ""
    with pytest.raises(penumbra.InputError, match="progress"):
        penumbra.render(cornell, spp=2, width=8, height=8, progress="yes")


# --- scenes ---------------------------------------------------------------------------------


def _room():
    """A 2 m box open at the front, a white floor, grey walls and an emissive ceiling panel."""
    p = np.array([[0, 0, 0], [2, 0, 0], [2, 0, 2], [0, 0, 2],
                  [0, 2, 0], [2, 2, 0], [2, 2, 2], [0, 2, 2],
                  [0.7, 1.99, 0.7], [1.3, 1.99, 0.7], [1.3, 1.99, 1.3], [0.7, 1.99, 1.3]],
                 dtype=np.float32)
    t = np.array([[0, 2, 1], [0, 3, 2],          # floor, facing up
                  [4, 5, 6], [4, 6, 7],          # ceiling, facing down
                  [0, 1, 5], [0, 5, 4],          # back wall z = 0
                  [0, 4, 7], [0, 7, 3],          # left wall x = 0
                  [1, 2, 6], [1, 6, 5],          # right wall x = 2
                  [8, 9, 10], [8, 10, 11]])      # the panel, facing down
    ids = np.array([0, 0, 1, 1, 1, 1, 1, 1, 1, 1, 2, 2])
    return p, t, ids


def test_materials_and_lights_as_objects_are_their_dicts(tmp_path):
    p, t, ids = _room()
    objects = penumbra.from_arrays(
        p, t, ids,
        materials=[penumbra.Material("floor", reflectance=[0.7, 0.7, 0.7]),
                   penumbra.Material("wall", reflectance=[0.5, 0.4, 0.3]),
                   penumbra.Material("panel", emission=[8, 8, 8])],
        lights=[penumbra.PointLight(position=[1, 1, 1], intensity=[1, 1, 1]),
                penumbra.SpotLight(position=[1, 1.5, 1], direction=[0, -1, 0],
                                   intensity=[2, 2, 2], outer_angle_deg=30)],
        camera=penumbra.Camera(position=[1, 1, 4], look_at=[1, 1, 0], fov_deg=50))
    dicts = penumbra.from_arrays(
        p, t, ids,
        materials=[{"name": "floor", "reflectance": [0.7, 0.7, 0.7]},
                   {"name": "wall", "reflectance": [0.5, 0.4, 0.3]},
                   {"name": "panel", "emission": [8, 8, 8]}],
        lights=[{"type": "point", "position": [1, 1, 1], "intensity": [1, 1, 1]},
                {"type": "spot", "position": [1, 1.5, 1], "direction": [0, -1, 0],
                 "intensity": [2, 2, 2], "outer_angle_deg": 30}],
        camera={"position": [1, 1, 4], "look_at": [1, 1, 0], "fov_deg": 50})
    assert objects.light_count == 2 and objects.material_count == 3
    a = penumbra.render(objects, spp=8, width=24, height=24, progress=False)
    b = penumbra.render(dicts, spp=8, width=24, height=24, progress=False)
    np.testing.assert_array_equal(a.image, b.image)
    # A light the library refuses is refused with its place, whichever way it was written.
    with pytest.raises(penumbra.InputError, match=r"arrays: lights\[0\].intensity\[0\]: -1"):
        penumbra.from_arrays(p, t, lights=[penumbra.PointLight(position=[1, 1, 1],
                                                               intensity=[-1, 1, 1])])


def test_a_scene_from_arrays_written_out_renders_the_same_from_the_cli(tmp_path, monkeypatch):
    p, t, ids = _room()
    # Material runs out of order: the floor's second triangle after the walls.
    t = np.concatenate([t[:1], t[2:10], t[1:2], t[10:]])
    ids = np.concatenate([ids[:1], ids[2:10], ids[1:2], ids[10:]])
    scene = penumbra.from_arrays(
        p, t, ids,
        materials=[penumbra.Material("floor", reflectance=[0.7, 0.7, 0.7]),
                   penumbra.Material("wall", reflectance=[0.5, 0.4, 0.3]),
                   penumbra.Material("panel", emission=[8, 8, 8])],
        lights=[penumbra.DirectionalLight(direction=[0.2, -1, -0.3], irradiance=[3, 3, 3])],
        camera=penumbra.Camera(position=[1, 1, 4], look_at=[1, 1, 0]),
        settings={"pathtrace": {"spp": 8}})
    files = scene.save(tmp_path / "room.json")
    assert files[-1] == str(tmp_path / "room.json") and len(files) == 5  # 4 runs of materials
    written = json.loads((tmp_path / "room.json").read_text())
    assert written["settings"] == {"pathtrace": {"spp": 8}}
    again = penumbra.load(tmp_path / "room.json")
    # The same triangles in the same numbering (what trace reports), the same lights.
    np.testing.assert_array_equal(again.flat_positions()[again.flat_indices()],
                                  scene.flat_positions()[scene.flat_indices()])
    assert again.light_count == 1 and again.material_count == 3
    a = penumbra.render(scene, width=20, height=20, progress=False)
    b = penumbra.render(again, width=20, height=20, progress=False)
    np.testing.assert_array_equal(a.image, b.image)
    assert a.stats["spp"] == 8
    cli = os.environ.get("PENUMBRA_CLI", "penumbra")
    import subprocess
    subprocess.run([cli, "render", str(tmp_path / "room.json"), "--width", "20", "--height",
                    "20", "-o", str(tmp_path / "cli.exr"), "--quiet"], check=True)
    np.testing.assert_array_equal(a.image, penumbra.read_image(tmp_path / "cli.exr"))
    with pytest.raises(penumbra.InputError, match="only a scene made from arrays"):
        penumbra.load("cornell").save(tmp_path / "x.json")
    # All or nothing: a target that cannot be written leaves no mesh file and no temporary one.
    (tmp_path / "blocked").mkdir()
    (tmp_path / "blocked" / "room.json").mkdir()
    with pytest.raises(penumbra.InputError, match="not a regular file"):
        scene.save(tmp_path / "blocked" / "room.json")
    assert sorted(p.name for p in (tmp_path / "blocked").iterdir()) == ["room.json"]
    with pytest.raises(penumbra.InputError, match="cannot write"):
        scene.save(tmp_path / "missing" / "room.json")
    # Relative in, relative out.
    monkeypatch.chdir(tmp_path)
    assert scene.save("again.json") == [f"again_mesh{k}.ply" for k in range(4)] + ["again.json"]


def test_a_file_with_another_camera_is_the_scene_file_that_says_so(tmp_path):
    baked = penumbra.bake("cornell", tmp_path / "baked", elements=200, progress=False)
    camera = penumbra.Camera(position=[0.5, 0.4, -0.6], look_at=[0.3, 0.2, 0.3], fov_deg=50)
    moved = penumbra.load(baked.gltf, camera=camera,
                          lights=[penumbra.PointLight(position=[0.3, 0.4, 0.3],
                                                      intensity=[0.2, 0.2, 0.2])])
    (tmp_path / "view.json").write_text(json.dumps({
        "meshes": [{"file": "baked/cornell.gltf"}],
        "camera": camera.to_dict(),
        "lights": [{"type": "point", "position": [0.3, 0.4, 0.3], "intensity": [0.2] * 3}]}))
    reference = penumbra.load(tmp_path / "view.json")
    a = penumbra.render(moved, spp=4, width=16, height=16, progress=False)
    b = penumbra.render(reference, spp=4, width=16, height=16, progress=False)
    np.testing.assert_array_equal(a.image, b.image)
    default = penumbra.render(baked.gltf, spp=4, width=16, height=16, progress=False)
    assert not np.array_equal(a.image, default.image)
    # A scene file with comments takes a camera too.
    (tmp_path / "commented.json").write_text(
        '// a view\n{"meshes": [{"file": "baked/cornell.gltf"}] /* one mesh, "quoted" */, '
        '"camera": {"position": [0, 0, -1], "look_at": [0, 0, 0]}}')
    (tmp_path / "plain.json").write_text(json.dumps({
        "meshes": [{"file": "baked/cornell.gltf"}], "camera": camera.to_dict()}))
    c = penumbra.render(penumbra.load(tmp_path / "commented.json", camera=camera), spp=4,
                        width=16, height=16, progress=False)
    d = penumbra.render(tmp_path / "plain.json", spp=4, width=16, height=16, progress=False)
    np.testing.assert_array_equal(c.image, d.image)
    with pytest.raises(penumbra.InputError, match="built-in"):
        penumbra.load("cornell", camera=camera)
    # A syntax error after a block comment of several lines is reported at its line in the file.
    (tmp_path / "broken.json").write_text('/* a\n   comment\n*/\n{"meshes": [}\n')
    with pytest.raises(penumbra.InputError, match="line 4"):
        penumbra.load(tmp_path / "broken.json", camera=camera)
