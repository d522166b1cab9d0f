"""`pip install .` into a fresh virtual environment, as a user does it (docs/python.md): the wheel
is built offline with Debian's setuptools and wheel, installs the module and the `penumbra`
command, runs the README's Python example from another folder, and uninstalls without leaving a
file. The wheel takes the module and CLI this build made (setup.py's PENUMBRA_PREBUILT), so the
test does not compile the library a second time."""

import glob
import os
import subprocess
import sys
import zipfile

import pytest

SOURCE = os.environ.get("PENUMBRA_SOURCE_DIR",
                        os.path.join(os.path.dirname(__file__), "..", ".."))
BUILD = os.environ.get("PENUMBRA_BUILD_DIR")


def run(args, **kwargs):
    return subprocess.run([str(a) for a in args], capture_output=True, text=True, timeout=600,
                          **kwargs)


def readme_example():
    with open(os.path.join(SOURCE, "README.md")) as f:
        readme = f.read()
    section = readme[readme.index("## Python"):]
    block = section[section.index("```python") + len("```python"):]
    return block[:block.index("```")]


@pytest.mark.skipif(not BUILD, reason="PENUMBRA_BUILD_DIR (set by CTest) names the build")
def test_pip_install_into_a_venv_runs_the_cli_and_the_readme_and_uninstalls_cleanly(tmp_path):
    if run([sys.executable, "-c", "import venv, ensurepip"]).returncode != 0:
        pytest.fail("python3-venv is missing (scripts/install-deps.sh installs it)")
    venv = tmp_path / "v"
    assert run([sys.executable, "-m", "venv", "--system-site-packages", venv]).returncode == 0
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PENUMBRA_CLI")}
    env["PENUMBRA_PREBUILT"] = BUILD
    env["PIP_DISABLE_PIP_VERSION_CHECK"] = "1"

    # The wheel, named honestly: this Python's tag and linux_x86_64, no manylinux claim.
    wheels = tmp_path / "wheels"
    built = run([venv / "bin" / "pip", "wheel", "--no-build-isolation", "--no-index", "--no-deps",
                 "-w", wheels, SOURCE], env=env)
    assert built.returncode == 0, built.stdout + built.stderr
    [wheel] = glob.glob(str(wheels / "penumbra-*.whl"))
    tag = f"cp{sys.version_info.major}{sys.version_info.minor}"
    assert os.path.basename(wheel).endswith(f"-{tag}-{tag}-linux_x86_64.whl"), wheel
    with zipfile.ZipFile(wheel) as z:
        names = z.namelist()
        cli_mode = z.getinfo("penumbra/bin/penumbra").external_attr >> 16
    assert "penumbra/__main__.py" in names and any(n.startswith("penumbra/_penumbra") for n in names)
    assert cli_mode & 0o111, "the CLI in the wheel is not executable"
    entry_points = [n for n in names if n.endswith("entry_points.txt")]
    assert entry_points

    installed = run([venv / "bin" / "pip", "install", "--no-build-isolation", "--no-index", SOURCE],
                    env=env)
    assert installed.returncode == 0, installed.stdout + installed.stderr

    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    # `import penumbra` from any folder finds the installed package, not the source tree.
    where = run([venv / "bin" / "python", "-c", "import penumbra; print(penumbra.__file__)"],
                cwd=elsewhere, env=env)
    assert where.returncode == 0, where.stderr
    assert where.stdout.strip().startswith(str(venv)), where.stdout
    # The console script and `python -m penumbra` are the CLI: output, files and exit codes.
    rendered = run([venv / "bin" / "penumbra", "render", "cornell", "--spp", "2", "--width", "16",
                    "--height", "16", "-o", "c.png", "--quiet"], cwd=elsewhere, env=env)
    assert rendered.returncode == 0, rendered.stderr
    assert (elsewhere / "c.png").read_bytes()[:4] == b"\x89PNG"
    bad = run([venv / "bin" / "python", "-m", "penumbra", "render", "missing.json"],
              cwd=elsewhere, env=env)
    assert bad.returncode == 2 and "missing.json" in bad.stderr, bad.stderr
    version = run([venv / "bin" / "penumbra", "--version"], env=env)
    assert version.returncode == 0 and version.stdout.startswith("penumbra ")
    # The README's Python example, as written, with the installed package.
    (elsewhere / "example.py").write_text(readme_example())
    example = run([venv / "bin" / "python", "example.py"], cwd=elsewhere, env=env)
    assert example.returncode == 0, example.stderr
    assert example.stdout.startswith("mean luminance ")
    assert (elsewhere / "cornell_python.png").exists()

    removed = run([venv / "bin" / "pip", "uninstall", "-y", "penumbra"], env=env)
    assert removed.returncode == 0, removed.stderr
    left = [p for p in glob.glob(str(venv / "lib" / "python*" / "site-packages" / "*"))
            if os.path.basename(p).lower().startswith("penumbra")]
    assert not left, left
    assert not (venv / "bin" / "penumbra").exists()
    gone = run([venv / "bin" / "python", "-c", "import penumbra"], cwd=elsewhere, env=env)
    assert gone.returncode != 0
