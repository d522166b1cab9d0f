"""`mpirun -np N penumbra ...` against one process (run by `make test`, docs/scaling.md).

Every distributed method is compared with the same command on one process: the path tracer and
`trace` byte for byte, the radiosity methods within the tolerances docs/scaling.md states. Then
what goes wrong: a rank that cannot start, a rank killed mid-run.
"""

import json
import os
import signal
import subprocess
import time

import pytest

CLI = os.environ.get("PENUMBRA_CLI", "penumbra")
REQUIRE_GL = os.environ.get("PENUMBRA_REQUIRE_GL") == "1"
# More ranks than this machine has cores run oversubscribed; CI runs as root.
MPIRUN = [os.environ.get("PENUMBRA_MPIRUN", "mpirun"), "--oversubscribe"]
if os.geteuid() == 0:
    MPIRUN.append("--allow-run-as-root")


def one(*args, cwd=None):
    """The CLI on one process (no launcher): its completed process (check=True)."""
    return subprocess.run([CLI, *map(str, args)], check=True, capture_output=True, text=True,
                          cwd=cwd, timeout=600)


def ranks(n, *args, check=True, cwd=None):
    """The CLI under `mpirun -np n`: its completed process."""
    p = subprocess.run([*MPIRUN, "-np", str(n), CLI, *map(str, args)], capture_output=True,
                       text=True, cwd=cwd, timeout=600)
    if check and p.returncode != 0:
        raise AssertionError(f"mpirun -np {n} failed ({p.returncode}):\n{p.stderr}")
    return p


def gl_available():
    if REQUIRE_GL:
        return True
    p = subprocess.run([CLI, "info", "--devices"], capture_output=True, text=True)
    return p.returncode == 0 and "OpenGL" in p.stdout


# --- the path tracer: the same image bit for bit ---------------------------------------------


@pytest.mark.parametrize("n", [2, 3])
def test_path_tracer_image_is_one_process_image_bit_for_bit(tmp_path, n):
    # Rows handed out on demand; each sample draws from its pixel's own streams, so who renders
    # a row does not change its bits.
    opts = ["cornell", "--width", 64, "--height", 48, "--spp", 8, "--quiet"]
    one("render", *opts, "--threads", 1, "-o", tmp_path / "one.pfm")
    ranks(n, "render", *opts, "-o", tmp_path / "n.pfm", "--stats", tmp_path / "n.json")
    assert (tmp_path / "one.pfm").read_bytes() == (tmp_path / "n.pfm").read_bytes()
    stats = json.loads((tmp_path / "n.json").read_text())
    assert stats["ranks"] == n
    # Every block was rendered once, by some rank; the rays add up to one process's.
    blocks = -(-48 // stats["block_rows"])
    assert sum(stats["blocks_per_rank"]) == blocks
    assert len(stats["blocks_per_rank"]) == n
    assert sum(stats["rays_per_rank"]) == stats["rays"]
    one("render", *opts, "-o", tmp_path / "again.pfm", "--stats", tmp_path / "one.json")
    assert json.loads((tmp_path / "one.json").read_text())["rays"] == stats["rays"]


def test_path_tracer_room_scan_over_ranks(tmp_path):
    # A real scene (69k-triangle scan, single-quad walls, one wound outwards) with a GPU-free
    # device choice: the same bits as one process.
    opts = ["scenes/room.json", "--width", 48, "--height", 36, "--spp", 2, "--quiet"]
    root = os.path.join(os.path.dirname(__file__), "..", "..")
    one("render", *opts, "-o", tmp_path / "one.pfm", cwd=root)
    ranks(2, "render", *opts, "-o", tmp_path / "two.pfm", cwd=root)
    assert (tmp_path / "one.pfm").read_bytes() == (tmp_path / "two.pfm").read_bytes()


def test_gpu_path_tracer_over_ranks(tmp_path):
    if not gl_available():
        pytest.skip("no OpenGL 4.5 context")
    opts = ["cornell", "--width", 40, "--height", 30, "--spp", 4, "--device", "gpu", "--quiet"]
    one("render", *opts, "-o", tmp_path / "one.pfm")
    ranks(2, "render", *opts, "-o", tmp_path / "two.pfm")
    assert (tmp_path / "one.pfm").read_bytes() == (tmp_path / "two.pfm").read_bytes()


@pytest.mark.parametrize("method", ["whitted", "photons"])
def test_whitted_and_photons_over_ranks(tmp_path, method):
    # Rows handed out on demand; every rank shoots the same photons (the same seeds), so the
    # image is one process's bit for bit.
    root = os.path.join(os.path.dirname(__file__), "..", "..")
    opts = ["scenes/cornell-glass.json", "--method", method, "--width", 40, "--height", 32,
            "--spp", 2, "--device", "cpu", "--quiet"]
    if method == "photons":
        opts += ["--photons", 20000, "--caustic-photons", 20000, "--final-gather", 4]
    one("render", *opts, "-o", tmp_path / "one.pfm", cwd=root)
    ranks(2, "render", *opts, "-o", tmp_path / "two.pfm", "--stats", tmp_path / "two.json",
          cwd=root)
    assert (tmp_path / "one.pfm").read_bytes() == (tmp_path / "two.pfm").read_bytes()
    stats = json.loads((tmp_path / "two.json").read_text())
    assert stats["ranks"] == 2 and stats["method"] == method
    assert sum(stats["rays_per_rank"]) == stats["rays"]


# --- trace: hits in the rays' order ----------------------------------------------------------


@pytest.fixture(scope="module")
def ray_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("rays") / "diffuse.bin"
    one("rays", "cornell", "--kind", "diffuse", "--count", 100003, "--seed", 7, "-o", path,
        "--quiet")
    return path


@pytest.mark.parametrize("n", [2, 3])
def test_trace_hits_are_one_process_hits_in_input_order(tmp_path, ray_file, n):
    one("trace", "cornell", "--rays", ray_file, "-o", tmp_path / "one.bin", "--quiet")
    ranks(n, "trace", "cornell", "--rays", ray_file, "-o", tmp_path / "n.bin", "--stats",
          tmp_path / "n.json", "--quiet")
    assert (tmp_path / "one.bin").read_bytes() == (tmp_path / "n.bin").read_bytes()
    stats = json.loads((tmp_path / "n.json").read_text())
    assert stats["ranks"] == n and stats["rays"] == 100003
    assert sum(stats["rays_per_rank"]) == 100003
    assert max(stats["rays_per_rank"]) - min(stats["rays_per_rank"]) <= 1


def test_trace_occlusion_over_ranks(tmp_path, ray_file):
    one("trace", "cornell", "--rays", ray_file, "--occlusion", "-o", tmp_path / "one.bin",
        "--quiet")
    ranks(3, "trace", "cornell", "--rays", ray_file, "--occlusion", "-o", tmp_path / "n.bin",
          "--quiet")
    data = (tmp_path / "n.bin").read_bytes()
    assert (tmp_path / "one.bin").read_bytes() == data
    assert 0 < sum(data) < len(data)  # some rays blocked, some not


def test_gpu_trace_over_ranks(tmp_path, ray_file):
    if not gl_available():
        pytest.skip("no OpenGL 4.5 context")
    one("trace", "cornell", "--rays", ray_file, "--device", "gpu", "-o", tmp_path / "one.bin",
        "--quiet")
    ranks(2, "trace", "cornell", "--rays", ray_file, "--device", "gpu", "-o",
          tmp_path / "two.bin", "--quiet")
    assert (tmp_path / "one.bin").read_bytes() == (tmp_path / "two.bin").read_bytes()


# --- matrix radiosity: rows of F on each rank, B exchanged each iteration -------------------


def read_pfm(path):
    import numpy as np
    with open(path, "rb") as f:
        assert f.readline().strip() == b"PF"
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4")
    return data.reshape(h, w, 3)


MATRIX = ["--method", "matrix", "--elements", 800, "--width", 64, "--height", 48, "--quiet"]


@pytest.mark.parametrize("n", [2, 3])
def test_matrix_jacobi_is_one_process_jacobi_bit_for_bit(tmp_path, n):
    # Rows in groups of four as one process takes them, sums in row order: the same iterates,
    # residuals and iteration count.
    one("render", "cornell", *MATRIX, "--solver", "jacobi", "-o", tmp_path / "one.pfm", "--stats",
        tmp_path / "one.json")
    ranks(n, "render", "cornell", *MATRIX, "--solver", "jacobi", "-o", tmp_path / "n.pfm",
          "--stats", tmp_path / "n.json")
    assert (tmp_path / "one.pfm").read_bytes() == (tmp_path / "n.pfm").read_bytes()
    a = json.loads((tmp_path / "one.json").read_text())
    b = json.loads((tmp_path / "n.json").read_text())
    assert a["history"] == b["history"] and a["iterations"] == b["iterations"]
    assert a["form_factor_rays"] == b["form_factor_rays"]
    assert b["ranks"] == n
    # Each rank holds its block of rows: about 1/n of the matrix.
    assert b["matrix_bytes_per_rank"] <= a["matrix_bytes"] / n * 1.02 + 4 * 4 * a["elements"]


def test_matrix_gauss_seidel_over_ranks_agrees_within_the_solver_tolerance(tmp_path):
    # Over ranks Gauss-Seidel sweeps each rank's rows in place and takes the others' as they were
    # (block Gauss-Seidel): the same fixed point, other iterates. It differs from one process no
    # more than one process's Jacobi does (both converged to --tolerance 1e-6).
    one("render", "cornell", *MATRIX, "--solver", "gauss-seidel", "-o", tmp_path / "gs.pfm")
    one("render", "cornell", *MATRIX, "--solver", "jacobi", "-o", tmp_path / "jacobi.pfm")
    ranks(3, "render", "cornell", *MATRIX, "--solver", "gauss-seidel", "-o",
          tmp_path / "gs3.pfm", "--stats", tmp_path / "gs3.json")
    assert json.loads((tmp_path / "gs3.json").read_text())["converged"]
    gs, jacobi, gs3 = (read_pfm(tmp_path / f) for f in ["gs.pfm", "jacobi.pfm", "gs3.pfm"])
    mean = gs.mean()
    assert abs(gs3.mean() - mean) / mean < 1e-3
    assert abs(gs3 - gs).max() / mean < 0.02
    assert abs(gs3.mean() - mean) <= 2 * abs(jacobi.mean() - mean) + 1e-6 * mean


def test_matrix_bake_over_ranks_writes_one_process_files(tmp_path):
    args = ["cornell", "--method", "matrix", "--solver", "jacobi", "--elements", 600, "--quiet"]
    one("bake", *args, "-o", tmp_path / "one")
    ranks(2, "bake", *args, "-o", tmp_path / "two")
    for name in ["cornell.gltf", "cornell.bin", "cornell_lightmap.exr"]:
        assert (tmp_path / "one" / name).read_bytes() == (tmp_path / "two" / name).read_bytes()


def test_matrix_room_scan_over_ranks(tmp_path):
    opts = ["scenes/room.json", "--method", "matrix", "--solver", "jacobi", "--elements", 600,
            "--width", 48, "--height", 36, "--quiet"]
    root = os.path.join(os.path.dirname(__file__), "..", "..")
    one("render", *opts, "-o", tmp_path / "one.pfm", cwd=root)
    ranks(2, "render", *opts, "-o", tmp_path / "two.pfm", cwd=root)
    assert (tmp_path / "one.pfm").read_bytes() == (tmp_path / "two.pfm").read_bytes()


def test_matrix_memory_guard_counts_each_rank(tmp_path):
    # 30,000 elements: 3.4 GiB of form factors on one process, a third of it (and as much in
    # exchange buffers) on each of three ranks. Under a 3 GB address-space limit one process is
    # refused before allocating; three ranks are not (a dry run stops before the work).
    args = ["render", "cornell", "--method", "matrix", "--elements", 30000, "--dry-run", "-o",
            tmp_path / "x.png"]
    limit = "ulimit -v 3000000; "
    p = subprocess.run(["bash", "-c", limit + " ".join(map(str, [CLI, *args]))],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and "needs 3.4 GiB" in p.stderr, p.stderr
    p = subprocess.run(["bash", "-c", limit + " ".join(map(str, [*MPIRUN, "-np", 3, CLI, *args]))],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert "memory are fine" in p.stdout


def test_methods_that_run_on_one_process_are_refused_over_ranks(tmp_path):
    p = ranks(2, "bake", "cornell", "--method", "stochastic", "-o", tmp_path / "b", check=False)
    assert p.returncode == 2
    ours = [l for l in p.stderr.splitlines() if l.startswith("penumbra:")]
    assert len(ours) == 1 and "over 2 ranks bake runs matrix and progressive" in ours[0], p.stderr
    assert not (tmp_path / "b").exists()


# --- progressive radiosity: receivers shared out, irradiance exchanged each shot -------------

PROGRESSIVE = ["--method", "progressive", "--elements", 4000, "--quiet"]
BAKED = ["cornell.gltf", "cornell.bin", "cornell_lightmap.exr"]


@pytest.mark.parametrize("n", [2, 3])
def test_progressive_bake_is_one_process_bake_bit_for_bit(tmp_path, n):
    # Every rank gathers at its receivers; with every receiver's irradiance exchanged, all ranks
    # hold the whole state, choose the same shooter and book the same energy as one process.
    one("bake", "cornell", *PROGRESSIVE, "-o", tmp_path / "one", "--stats", tmp_path / "one.json")
    ranks(n, "bake", "cornell", *PROGRESSIVE, "-o", tmp_path / "n", "--stats", tmp_path / "n.json")
    for name in BAKED:
        assert (tmp_path / "one" / name).read_bytes() == (tmp_path / "n" / name).read_bytes()
    a = json.loads((tmp_path / "one.json").read_text())
    b = json.loads((tmp_path / "n.json").read_text())
    for key in ["history", "shooters", "rays", "emitted_w", "absorbed_w", "escaped_w"]:
        assert a[key] == b[key], key


def test_progressive_adaptive_room_over_ranks(tmp_path):
    # The scan room with adaptive subdivision at shadow boundaries, rendered: the same bits.
    opts = ["scenes/room.json", "--method", "progressive", "--elements", 3000, "--adaptive",
            "--width", 48, "--height", 36, "--quiet"]
    root = os.path.join(os.path.dirname(__file__), "..", "..")
    one("render", *opts, "-o", tmp_path / "one.pfm", cwd=root)
    ranks(2, "render", *opts, "-o", tmp_path / "two.pfm", cwd=root)
    assert (tmp_path / "one.pfm").read_bytes() == (tmp_path / "two.pfm").read_bytes()


def test_progressive_stop_request_checkpoint_resumes_on_another_rank_count(tmp_path):
    # SIGUSR1 to mpirun (which passes it on to every rank) stops all ranks at one iteration;
    # rank 0 writes the checkpoint; three ranks finish it, and the result is that of one
    # process that was never stopped.
    args = ["bake", "cornell", "--method", "progressive", "--elements", 20000, "--tolerance",
            "1e-5", "--iterations", 400]
    proc = subprocess.Popen([*MPIRUN, "-np", "2", CLI, *map(str, args), "-o",
                             str(tmp_path / "stopped")],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    # The solver announces its atlas once the stop request is honoured (scripts wait for it).
    line = ""
    deadline = time.time() + 120
    while "lightmap texels" not in line and time.time() < deadline:
        line = proc.stderr.readline()
        if not line and proc.poll() is not None:
            break
    time.sleep(1.0)
    proc.send_signal(signal.SIGUSR1)
    _, err = proc.communicate(timeout=300)
    checkpoint = tmp_path / "stopped" / "cornell.checkpoint"
    if proc.returncode == 0:
        pytest.skip("the bake finished before the stop request arrived")
    assert proc.returncode == 128 + signal.SIGUSR1, err
    assert "checkpoint written" in err and checkpoint.exists()
    one(*args, "-o", tmp_path / "whole")
    ranks(3, *args, "--resume", checkpoint, "-o", tmp_path / "resumed")
    for name in BAKED:
        whole = (tmp_path / "whole" / name).read_bytes()
        assert whole == (tmp_path / "resumed" / name).read_bytes(), name
    assert not checkpoint.exists()  # a completed run removes the checkpoint it continued


# --- the library: penumbra::api calls over a communicator -----------------------------------


@pytest.mark.parametrize("n", [2, 3])
def test_api_over_a_communicator(n):
    program = os.environ.get("PENUMBRA_API_MPI_TEST")
    if not program:
        pytest.skip("PENUMBRA_API_MPI_TEST is not set (ctest sets it)")
    p = subprocess.run([*MPIRUN, "-np", str(n), program], capture_output=True, text=True,
                       timeout=600)
    assert p.returncode == 0, p.stdout + p.stderr
    assert f"api over {n} ranks: 0 failed checks" in p.stdout


# --- what goes wrong -------------------------------------------------------------------------


def test_bad_option_is_one_error_line_from_rank_0(tmp_path):
    p = ranks(3, "render", "cornell", "--spp", "-4", "-o", tmp_path / "x.png", check=False)
    assert p.returncode == 2
    ours = [l for l in p.stderr.splitlines() if l.startswith("penumbra:")]
    assert len(ours) == 1 and "--spp" in ours[0], p.stderr
    assert not (tmp_path / "x.png").exists()


def test_a_rank_that_cannot_start_stops_them_all(tmp_path):
    # Rank 1 runs where the scene file is not (an MPMD launch with two working directories): it
    # says so, rank 0 names it, both exit 2 before any work, and nothing is written.
    here, there = tmp_path / "here", tmp_path / "there"
    here.mkdir()
    there.mkdir()
    (here / "plane.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    out = tmp_path / "out.png"
    args = ["render", "plane.obj", "--width", 8, "--height", 8, "--spp", 1, "-o", out]
    p = subprocess.run([*MPIRUN, "-np", "1", "-wdir", here, CLI, *map(str, args), ":", "-np", "1",
                        "-wdir", there, CLI, *map(str, args)],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 2, p.stderr
    assert "rank 1 of 2: plane.obj: no such file" in p.stderr
    assert "rank 1 of 2 could not start" in p.stderr
    assert not out.exists()


def test_a_killed_rank_ends_the_run_with_an_error_not_a_hang(tmp_path):
    out = tmp_path / "k.png"
    proc = subprocess.Popen([*MPIRUN, "-np", "2", CLI, "render", "cornell", "--spp", "100000",
                             "--width", "64", "--height", "64", "-o", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        # The ranks are mpirun's children; wait until both run and have begun the work.
        deadline = time.time() + 60
        children = []
        while time.time() < deadline and len(children) < 2:
            time.sleep(0.2)
            r = subprocess.run(["pgrep", "-P", str(proc.pid)], capture_output=True, text=True)
            children = [int(x) for x in r.stdout.split()]
        assert len(children) == 2, "the ranks did not start"
        time.sleep(2.0)
        os.kill(max(children), signal.SIGKILL)  # the later-started rank
        _, err = proc.communicate(timeout=60)  # a hang fails here
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode != 0
    assert "exited on signal 9" in err, err
    assert "stopped by a signal" in err, err
    assert not out.exists()
