"""examples/penumbra.ipynb executed as a user would run it (`jupyter nbconvert --execute`, Debian's
python3-nbconvert and python3-ipykernel): every cell runs without an error and makes what it
says: the bake's files, the lightmap with its atlas, two views, the lux grid (run by `make test`;
skipped with a message when those packages are missing)."""

import base64
import os
import shutil
import subprocess
import sys

import pytest

SOURCE = os.environ.get("PENUMBRA_SOURCE_DIR",
                        os.path.join(os.path.dirname(__file__), "..", ".."))


def test_the_example_notebook_runs_and_shows_its_figures(tmp_path):
    for module, package in (("nbconvert", "python3-nbconvert"), ("ipykernel", "python3-ipykernel"),
                            ("matplotlib", "python3-matplotlib")):
        if subprocess.run([sys.executable, "-c", f"import {module}"]).returncode != 0:
            pytest.skip(f"{package} is not installed (scripts/install-deps.sh installs it)")
    import nbformat

    # Run in a folder of its own: the notebook writes its bake and CSV where it runs.
    notebook = tmp_path / "penumbra.ipynb"
    shutil.copy(os.path.join(SOURCE, "examples", "penumbra.ipynb"), notebook)
    env = dict(os.environ, PENUMBRA_SOURCE_DIR=os.path.abspath(SOURCE),
               PYDEVD_DISABLE_FILE_VALIDATION="1")
    env.pop("MPLBACKEND", None)  # the kernel's inline backend puts figures in the notebook
    if env.get("PYTHONPATH"):  # the kernel runs in tmp_path
        env["PYTHONPATH"] = os.pathsep.join(os.path.abspath(p)
                                            for p in env["PYTHONPATH"].split(os.pathsep))
    run = subprocess.run([sys.executable, "-m", "nbconvert", "--to", "notebook", "--execute",
                          "--ExecutePreprocessor.timeout=600", "--output", "executed.ipynb",
                          str(notebook)], cwd=tmp_path, env=env, capture_output=True, text=True,
                         timeout=900)
    assert run.returncode == 0, run.stderr[-4000:]
    executed = nbformat.read(str(tmp_path / "executed.ipynb"), as_version=4)
    images, text = [], []
    for cell in executed.cells:
        for out in cell.get("outputs", []):
            assert out.get("output_type") != "error", "\n".join(out.get("traceback", []))
            if out.get("output_type") == "stream" and out.get("name") == "stdout":
                text.append(out["text"])
            data = out.get("data", {})
            if "image/png" in data:
                images.append(base64.b64decode(data["image/png"]))
            if "text/html" in data:
                assert "data:image/png;base64," in data["text/html"]
    assert len(images) >= 3 and all(i[:4] == b"\x89PNG" for i in images)
    stdout = "".join(text)
    assert "room.gltf" in stdout and "E_avg" in stdout
    assert (tmp_path / "baked" / "room_lightmap.exr").exists()
    assert (tmp_path / "grid.csv").exists()
