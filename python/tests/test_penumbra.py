"""The Python module against the CLI, closed forms and bad input (run by `make test`)."""

import json
import math
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest

import penumbra

CLI = os.environ.get("PENUMBRA_CLI", "penumbra")
REQUIRE_GL = os.environ.get("PENUMBRA_REQUIRE_GL") == "1"


def cli(*args, cwd=None):
    """Runs the CLI; returns its completed process (check=True)."""
    return subprocess.run([CLI, *map(str, args)], check=True, capture_output=True, text=True,
                          cwd=cwd)


# --- render ---------------------------------------------------------------------------------


def test_render_is_the_cli_render_bit_for_bit(tmp_path):
    # The path tracer's image does not depend on the thread count: the same options give the
    # same floats through either front end.
    exr = tmp_path / "cli.exr"
    cli("render", "cornell", "--spp", 8, "--width", 40, "--height", 30, "--threads", 1, "-o", exr,
        "--quiet")
    result = penumbra.render("cornell", spp=8, width=40, height=30)
    assert result.image.shape == (30, 40, 3)
    assert result.image.dtype == np.float32
    np.testing.assert_array_equal(result.image, penumbra.read_image(exr))
    assert result.stats["method"] == "pathtrace"
    assert result.stats["spp"] == 8
    assert result.stats["rays"] > 30 * 40 * 8


def test_matrix_radiosity_is_the_cli_result(tmp_path):
    exr, stats = tmp_path / "m.exr", tmp_path / "m.json"
    cli("render", "cornell", "--method", "matrix", "--elements", 400, "--width", 32, "--height", 32,
        "-o", exr, "--stats", stats, "--quiet")
    result = penumbra.render("cornell", "matrix", elements=400, width=32, height=32)
    np.testing.assert_array_equal(result.image, penumbra.read_image(exr))
    cli_stats = json.loads(stats.read_text())
    assert result.stats["elements"] == cli_stats["elements"]
    assert result.stats["method"] == "matrix"


def test_a_mirror_from_arrays_shows_the_emitter_in_every_method():
    # A tinted mirror facing the camera, and behind the camera a large emitter: every pixel is
    # the mirror's reflectance times the emitter's radiance, through the path tracer, Whitted ray
    # tracing and photon mapping alike.
    positions = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0],
                          [-5, -5, 2], [-5, 5, 2], [5, 5, 2], [5, -5, 2]], dtype=np.float32)
    triangles = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]], dtype=np.uint32)
    scene = penumbra.from_arrays(
        positions, triangles, material_ids=np.array([0, 0, 1, 1], dtype=np.uint32),
        materials=[{"name": "mirror", "type": "mirror", "specular": [0.9, 0.6, 0.3]},
                   {"name": "light", "reflectance": [0, 0, 0], "emission": [2, 3, 4]}],
        camera={"position": [0, 0, 1], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov_deg": 17})
    expected = np.array([1.8, 1.8, 1.2], dtype=np.float32)
    for method in ("pathtrace", "whitted", "photons"):
        result = penumbra.render(scene, method, width=8, height=8, spp=2, device="cpu")
        np.testing.assert_allclose(result.image, np.broadcast_to(expected, (8, 8, 3)), rtol=1e-4)
        assert result.stats["method"] == method


def test_render_writes_the_outputs_it_is_given(tmp_path):
    out = tmp_path / "a.png"
    stats = tmp_path / "s.json"
    result = penumbra.render("cornell", spp=2, width=16, height=16, output=[out], stats=stats)
    assert out.exists() and stats.exists()
    assert json.loads(stats.read_text()) == result.stats


def point_light_over_a_plane(reflectance, intensity, height):
    # A 200 m square of two triangles, a point light `height` above its centre and a camera
    # looking straight down at the centre through a narrow field of view.
    h = 100.0
    positions = [[-h, 0, -h], [h, 0, -h], [h, 0, h], [-h, 0, h]]
    indices = [[0, 2, 1], [0, 3, 2]]  # counter-clockwise seen from above (+y)
    return penumbra.from_arrays(
        positions, indices, material_ids=[0, 0],
        materials=[{"name": "grey", "reflectance": [reflectance] * 3, "two_sided": False}],
        lights=[{"type": "point", "position": [0, height, 0], "intensity": [intensity] * 3}],
        camera={"position": [0, 2 * height, 0], "look_at": [0, 0, 0], "up": [0, 0, 1],
                "fov_deg": 1.0})


def test_a_scene_from_arrays_gives_the_closed_form_radiance():
    # Directly below a point light of intensity I at height h, a Lambertian plane of reflectance
    # rho has irradiance I / h^2 and radiance rho I / (pi h^2); nothing else contributes.
    rho, intensity, height = 0.5, 10.0, 1.0
    scene = point_light_over_a_plane(rho, intensity, height)
    assert (scene.triangle_count, scene.light_count, scene.material_count) == (2, 1, 1)
    result = penumbra.render(scene, spp=4, width=9, height=9)
    expected = rho * intensity / (math.pi * height * height)
    centre = result.image[4, 4]
    np.testing.assert_allclose(centre, expected, rtol=1e-3)
    # Across a 1-degree view the cos^3 falloff is below 1e-4.
    np.testing.assert_allclose(result.image, expected, rtol=2e-3)


def test_progress_reaches_the_end_and_stays_in_range():
    seen = []
    penumbra.render("cornell", spp=4, width=64, height=64,
                    progress=lambda stage, fraction: seen.append((stage, fraction)))
    assert seen, "no progress reported"
    assert all(0.0 <= f <= 1.0 for _, f in seen)
    assert seen[-1] == ("rendering", 1.0)


def test_an_exception_in_the_progress_callback_stops_the_render_and_is_raised():
    def fail(stage, fraction):
        raise ZeroDivisionError("from the callback")

    with pytest.raises(ZeroDivisionError, match="from the callback"):
        penumbra.render("cornell", spp=64, width=256, height=256, progress=fail)


def test_the_gil_is_released_during_a_render():
    ticks = 0
    done = threading.Event()

    def work():
        penumbra.render("cornell", spp=32, width=96, height=96)
        done.set()

    thread = threading.Thread(target=work)
    thread.start()
    while not done.is_set():
        ticks += 1
        time.sleep(0.001)
    thread.join()
    assert ticks > 20


# --- bake -----------------------------------------------------------------------------------


def test_bake_returns_the_atlas_it_writes(tmp_path):
    result = penumbra.bake("cornell", tmp_path / "baked", elements=300, lightmap_size=64)
    assert result.lightmap.shape == (64, 64, 3)
    written = sorted(p.name for p in (tmp_path / "baked").iterdir())
    exr = [n for n in written if n.endswith(".exr")]
    assert len(exr) == 1 and any(n.endswith(".gltf") for n in written)
    np.testing.assert_array_equal(result.lightmap, penumbra.read_image(tmp_path / "baked" / exr[0]))
    # The CLI's bake of the same options gives the same atlas.
    cli("bake", "cornell", "--elements", 300, "--lightmap-size", 64, "-o", tmp_path / "cli",
        "--quiet")
    np.testing.assert_array_equal(result.lightmap, penumbra.read_image(tmp_path / "cli" / exr[0]))
    assert result.stats["method"] == "matrix"


# --- trace ----------------------------------------------------------------------------------


def test_trace_gives_the_cli_hits(tmp_path):
    rays_file, hits_file = tmp_path / "rays.bin", tmp_path / "hits.bin"
    cli("rays", "cornell", "--kind", "diffuse", "--count", 20000, "--seed", 3, "-o", rays_file)
    cli("trace", "cornell", "--rays", rays_file, "-o", hits_file, "--device", "cpu", "--quiet")
    rays = np.fromfile(rays_file, dtype=np.float32).reshape(-1, 8)
    expected = np.fromfile(hits_file, dtype=np.dtype(
        [("triangle", "<i4"), ("t", "<f4"), ("u", "<f4"), ("v", "<f4")]))
    hits = penumbra.trace("cornell", rays, device="cpu")
    for key in ("triangle", "t", "u", "v"):
        np.testing.assert_array_equal(hits[key], expected[key])
    assert hits["stats"]["rays"] == len(rays)
    occluded = penumbra.trace("cornell", rays, device="cpu", occlusion=True)["occluded"]
    np.testing.assert_array_equal(occluded, expected["triangle"] >= 0)


def test_trace_on_the_gpu_agrees_with_the_cpu():
    if not REQUIRE_GL:
        pytest.skip("PENUMBRA_REQUIRE_GL=1 runs the GPU back ends")
    scene = penumbra.load("cornell")
    rng = np.random.default_rng(5)
    n = 4000
    origins = rng.uniform([0.05, 0.05, 0.05], [0.5, 0.5, 0.5], size=(n, 3))
    dirs = rng.normal(size=(n, 3))
    rays = np.hstack([origins, np.zeros((n, 1)), dirs, np.full((n, 1), np.inf)]).astype(np.float32)
    cpu = penumbra.trace(scene, rays, device="cpu")
    for device in ("gpu", "hybrid"):
        other = penumbra.trace(scene, rays, device=device)
        assert other["stats"]["device"] == device
        same = other["triangle"] == cpu["triangle"]
        assert same.mean() > 0.999, device
        np.testing.assert_allclose(other["t"][same], cpu["t"][same], rtol=1e-4)


def test_render_on_the_gpu_is_the_cpu_image():
    # The wavefront path tracer through the GPU Ray Engine gives the CPU's image (docs/cli.md).
    if not REQUIRE_GL:
        pytest.skip("PENUMBRA_REQUIRE_GL=1 runs the GPU back ends")
    cpu = penumbra.render("cornell", spp=4, width=24, height=24, device="cpu")
    gpu = penumbra.render("cornell", spp=4, width=24, height=24, device="gpu")
    assert gpu.stats["device"] == "gpu"
    np.testing.assert_allclose(gpu.image, cpu.image, rtol=1e-4, atol=1e-6)


def test_trace_hits_a_quad_where_geometry_says():
    # Rays straight down onto the unit square z = 0 at height 2: t = 2, inside it a hit, outside
    # a miss (t infinite, triangle -1).
    scene = penumbra.from_arrays([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]],
                                 [[0, 1, 2], [0, 2, 3]])
    xy = np.array([[0.25, 0.5], [0.75, 0.25], [1.5, 0.5], [-0.1, 0.2]], dtype=np.float32)
    rays = np.zeros((4, 8), dtype=np.float32)
    rays[:, 0:2], rays[:, 2], rays[:, 6], rays[:, 7] = xy, 2.0, -1.0, np.inf
    hits = penumbra.trace(scene, rays, device="cpu")
    np.testing.assert_array_equal(hits["triangle"][:2] >= 0, [True, True])
    np.testing.assert_array_equal(hits["triangle"][2:], [-1, -1])
    np.testing.assert_allclose(hits["t"][:2], 2.0)
    assert np.all(np.isinf(hits["t"][2:]))


# --- images ---------------------------------------------------------------------------------


def test_images_round_trip(tmp_path):
    image = np.random.default_rng(1).uniform(0, 4, size=(5, 7, 3)).astype(np.float32)
    penumbra.write_image(tmp_path / "x.exr", image)
    np.testing.assert_array_equal(penumbra.read_image(tmp_path / "x.exr"), image)
    penumbra.write_image(tmp_path / "x.png", image, tonemap="exposure", exposure=-1.0)
    png = penumbra.read_image(tmp_path / "x.png")
    assert png.shape == (5, 7, 3) and 0.0 <= png.min() and png.max() <= 1.0


# --- bad input ------------------------------------------------------------------------------


def test_bad_input_raises_the_library_message(tmp_path):
    with pytest.raises(penumbra.InputError, match="/nonexistent.obj"):
        penumbra.load("/nonexistent.obj")
    broken = tmp_path / "broken.obj"
    broken.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n")
    with pytest.raises(penumbra.InputError, match="broken.obj") as e:
        penumbra.load(broken)
    assert e.value.kind == "input" and e.value.exit_code == 2
    with pytest.raises(ValueError, match="spp: 0 is out of range"):
        penumbra.render("cornell", spp=0)
    with pytest.raises(penumbra.InputError, match="no_such_option: is not an option"):
        penumbra.render("cornell", no_such_option=3)
    with pytest.raises(penumbra.InputError, match="unknown --method 'nope'"):
        penumbra.render("cornell", "nope")


def test_keyword_arguments_are_typed_and_checked_before_any_work():
    # Each keyword is its option's typed value, checked by the library's description of it.
    with pytest.raises(penumbra.InputError, match='spp: must be an integer, not "64"'):
        penumbra.render("cornell", spp="64")
    with pytest.raises(penumbra.InputError, match="width: must be an integer"):
        penumbra.render("cornell", width=32.5)
    with pytest.raises(penumbra.InputError,
                       match="light-samples: applies to --method whitted and photons only"):
        penumbra.render("cornell", light_samples=2)
    with pytest.raises(penumbra.InputError, match="boundary"):
        penumbra.render("cornell", "progressive", adaptive=True, boundary=[0.5])
    # NumPy numbers and paths are what users pass; a number where a real is asked is fine.
    a = penumbra.render("cornell", spp=np.int64(2), width=8, height=8, max_depth=3)
    b = penumbra.render("cornell", spp=2, width=8, height=8, max_depth=3)
    np.testing.assert_array_equal(a.image, b.image)
    assert a.stats["max_depth"] == 3


def test_help_and_methods_come_from_the_descriptions():
    doc = penumbra.render.__doc__
    assert "spp (int; [1, 4096]) [pathtrace: 64 in [1, 1048576], whitted: 4" in doc
    assert "light_samples (int" in doc and "[whitted" in doc
    assert "texel_density" in penumbra.bake.__doc__
    listed = {m["name"]: m for m in penumbra.methods()}
    assert set(listed) == {"pathtrace", "whitted", "photons", "matrix", "progressive",
                           "stochastic", "sss", "lpv"}
    assert "spp" in listed["pathtrace"]["options"]
    assert "light_samples" in listed["whitted"]["options"]
    assert "light_samples" not in listed["pathtrace"]["options"]
    assert listed["matrix"]["bakes"] and listed["pathtrace"]["bakes"]
    assert not listed["whitted"]["bakes"]


def test_bad_arrays_raise_naming_the_place():
    quad = [[0, 0, 0], [1, 0, 0], [1, 1, 0]]
    with pytest.raises(penumbra.InputError, match=r"arrays: mesh 0 .*vertex 1: .*not a finite"):
        penumbra.from_arrays([[0, 0, 0], [1, np.nan, 0], [1, 1, 0]], [[0, 1, 2]])
    with pytest.raises(penumbra.InputError, match="out of range|index"):
        penumbra.from_arrays(quad, [[0, 1, 5]])
    with pytest.raises(penumbra.InputError, match="material"):
        penumbra.from_arrays(quad, [[0, 1, 2]], material_ids=[3],
                             materials=[{"reflectance": [0.5, 0.5, 0.5]}])
    with pytest.raises(penumbra.InputError, match=r"materials\[0\].reflectance"):
        penumbra.from_arrays(quad, [[0, 1, 2]], materials=[{"reflectance": [2, 0, 0]}])
    with pytest.raises(penumbra.InputError, match="N x 3"):
        penumbra.from_arrays([0, 1, 2], [[0, 1, 2]])
    with pytest.raises(penumbra.InputError, match="N x 8"):
        penumbra.trace("cornell", np.zeros((3, 7), dtype=np.float32))
    rays = np.zeros((2, 8), dtype=np.float32)
    rays[:, 4] = 1.0
    rays[1, 4:7] = 0.0
    with pytest.raises(penumbra.InputError, match="ray 1: direction is zero"):
        penumbra.trace("cornell", rays, device="cpu")


def test_rays_that_would_not_fit_are_refused_before_allocating(tmp_path):
    # 50M rays (1.6 GB, mapped but never touched) under a 4 GB address-space limit: tracing them
    # needs 3 GB more, which is refused with the amounts before anything is allocated.
    script = tmp_path / "big.py"
    script.write_text(textwrap.dedent("""
        import resource, numpy as np, penumbra
        resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))
        rays = np.zeros((50_000_000, 8), dtype=np.float32)
        try:
            penumbra.trace("cornell", rays, device="cpu")
            print("traced")
        except penumbra.InputError as e:
            print(e)
        """))
    run = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 0, run.stderr
    assert run.stdout.startswith("tracing 50000000 rays needs 3.0 GiB, more than is available"), \
        run.stdout


def test_indices_must_be_whole_numbers_and_huge_arrays_are_refused_before_copying():
    quad = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]
    with pytest.raises(penumbra.InputError, match=r"indices: value 2 \(2\.7\) is not a whole"):
        penumbra.from_arrays(quad, [[0, 1, 2.7]])
    with pytest.raises(penumbra.InputError, match=r"indices: value 1 \(-1\.0\) is not a whole"):
        penumbra.from_arrays(quad, np.array([[0, -1, 2]], dtype=np.int64))
    with pytest.raises(penumbra.InputError, match="material_ids: value 0"):
        penumbra.from_arrays(quad, [[0, 1, 2]], material_ids=[0.5],
                             materials=[{"reflectance": [0.5, 0.5, 0.5]}])
    # Whole numbers of any type are taken.
    scene = penumbra.from_arrays(np.array(quad, dtype=np.float64),
                                 np.array([[0, 1, 2], [0, 2, 3]], dtype=np.float64))
    assert scene.triangle_count == 2
    # 10^12 rays as a broadcast view (no memory behind it): refused with the amount, not a
    # TypeError from the conversion.
    ray = np.array([0, 0, -1, 0, 0, 0, 1, 1e30], dtype=np.float32)
    with pytest.raises(penumbra.InputError, match=r"tracing 1000000000000 rays needs .* more than"):
        penumbra.trace(scene, np.broadcast_to(ray, (10**12, 8)), device="cpu")
    with pytest.raises(penumbra.InputError, match="rays must hold numbers, not dtype"):
        penumbra.trace(scene, [["a"] * 8], device="cpu")


# --- Ctrl-C ---------------------------------------------------------------------------------


def run_interrupted(script, tmp_path, after_s=1.0):
    """Runs `script` in a fresh interpreter and sends it SIGINT `after_s` seconds after it prints
    "started" (from its progress callback, once the work proper has begun); returns (seconds from
    the signal to the end, stdout, stderr, exit code)."""
    path = tmp_path / "script.py"
    path.write_text(textwrap.dedent(script))
    proc = subprocess.Popen([sys.executable, str(path)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=tmp_path)
    line = proc.stdout.readline().strip()
    assert line == "started", line + proc.stderr.read()
    time.sleep(after_s)
    proc.send_signal(signal.SIGINT)
    sent = time.monotonic()
    out, err = proc.communicate(timeout=120)
    return time.monotonic() - sent, out, err, proc.returncode


# Prints "started" once the named stage reports progress.
STARTED = """
    import penumbra, sys, time
    announced = False
    def progress(stage, fraction):
        global announced
        if stage == STAGE and not announced:
            announced = True
            print("started", flush=True)
    """


def test_ctrl_c_interrupts_a_render_with_keyboard_interrupt(tmp_path):
    elapsed, out, err, code = run_interrupted(STARTED.replace("STAGE", '"rendering"') + """
    start = time.monotonic()
    try:
        penumbra.render("cornell", spp=100000, width=256, height=256, progress=progress)
        print("finished")
    except KeyboardInterrupt:
        print("KeyboardInterrupt after", time.monotonic() - start)
    """, tmp_path)
    assert code == 0, err
    assert "KeyboardInterrupt" in out, out + err
    assert elapsed < 10.0  # stopped at the next pixel, not at the end of a 100000-spp render


def test_ctrl_c_during_a_bake_leaves_its_checkpoint(tmp_path):
    elapsed, out, err, code = run_interrupted(STARTED.replace("STAGE", '"shooting"') + """
    try:
        penumbra.bake("cornell", "baked", method="progressive", elements=200000,
                      tolerance=1e-9, iterations=1000000, progress=progress)
        print("finished")
    except KeyboardInterrupt:
        print("KeyboardInterrupt")
    """, tmp_path)
    assert code == 0, err
    assert "KeyboardInterrupt" in out, out + err
    checkpoints = list((tmp_path / "baked").glob("*.checkpoint"))
    assert len(checkpoints) == 1, sorted(p.name for p in (tmp_path / "baked").iterdir())
    assert checkpoints[0].stat().st_size > 0
    # The checkpoint continues the bake, as the CLI's does.
    resumed = penumbra.bake("cornell", tmp_path / "baked", method="progressive", elements=200000,
                            resume=checkpoints[0], iterations=5)
    assert resumed.lightmap is not None and resumed.lightmap.max() > 0


# --- the README ---------------------------------------------------------------------------


def test_the_readme_example_runs_as_written(tmp_path):
    source = os.environ.get("PENUMBRA_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
    with open(os.path.join(source, "README.md")) as f:
        readme = f.read()
    section = readme[readme.index("## Python"):]
    block = section[section.index("```python") + len("```python"):]
    code = block[:block.index("```")]
    assert 1 < len(code.strip().splitlines()) <= 5, code
    script = tmp_path / "example.py"
    script.write_text(code)
    run = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True,
                         text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert run.stdout.startswith("mean luminance ")
    image = penumbra.read_image(tmp_path / "cornell_python.png")
    assert image.shape == (256, 256, 3)
