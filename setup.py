"""Builds the wheel of `pip install .`: CMake builds the library, the Python module and the CLI
(targets penumbra_python and penumbra_cli) in build-wheel/cmake, and the package is the build
tree's python/penumbra (the module, __init__.py, __main__.py and bin/penumbra, the CLI the
`penumbra` console script runs).

PENUMBRA_PREBUILT=DIR takes the package from an existing CMake build tree DIR instead of building
(the test of the wheel uses the tree `make test` built). CMAKE_ARGS adds configure options, e.g.
CMAKE_ARGS="-DPENUMBRA_NATIVE=OFF" for a wheel that runs on other x86-64 machines (the default
build is optimised for this machine's processor, and the wheel's tag says only linux_x86_64).
"""

import os
import re
import shlex
import shutil
import subprocess
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = os.path.dirname(os.path.abspath(__file__))


def project_version():
    with open(os.path.join(ROOT, "CMakeLists.txt")) as f:
        match = re.search(r"project\(penumbra VERSION ([0-9.]+)", f.read())
    if not match:
        sys.exit("setup.py: CMakeLists.txt has no project(penumbra VERSION ...)")
    return match.group(1)


class CMakeBuild(build_ext):
    """The extension and the CLI from CMake, copied into the package being built."""

    def build_extension(self, ext):
        tree = os.environ.get("PENUMBRA_PREBUILT")
        if tree:
            tree = os.path.abspath(tree)
        else:
            tree = os.path.join(ROOT, "build-wheel", "cmake")
            configure = ["cmake", "-S", ROOT, "-B", tree, "-DCMAKE_BUILD_TYPE=Release",
                         "-DPENUMBRA_BUILD_TESTS=OFF", "-DPENUMBRA_BUILD_BENCH=OFF"]
            if shutil.which("ninja"):
                configure += ["-G", "Ninja"]
            configure += shlex.split(os.environ.get("CMAKE_ARGS", ""))
            subprocess.check_call(configure)
            subprocess.check_call(["cmake", "--build", tree, "-j", str(os.cpu_count() or 1),
                                   "--target", "penumbra_python", "penumbra_cli"])
        package = os.path.join(tree, "python", "penumbra")
        module = [f for f in os.listdir(package) if f.startswith("_penumbra") and f.endswith(".so")]
        cli = os.path.join(package, "bin", "penumbra")
        if len(module) != 1 or not os.access(cli, os.X_OK):
            sys.exit(f"setup.py: {package} has no built module and CLI (build the targets "
                     "penumbra_python and penumbra_cli)")
        target = self.get_ext_fullpath(ext.name)
        os.makedirs(os.path.dirname(target), exist_ok=True)
        shutil.copy2(os.path.join(package, module[0]), target)
        os.makedirs(os.path.join(os.path.dirname(target), "bin"), exist_ok=True)
        shutil.copy2(cli, os.path.join(os.path.dirname(target), "bin", "penumbra"))


setup(
    version=project_version(),
    packages=["penumbra"],
    package_dir={"penumbra": "python/penumbra"},
    # Declared so the wheel is tagged for this platform (cp3XX-cp3XX-linux_x86_64); CMake builds it.
    ext_modules=[Extension("penumbra._penumbra", sources=[])],
    cmdclass={"build_ext": CMakeBuild},
    options={"build": {"build_base": os.path.join("build-wheel", "setuptools")},
             "egg_info": {"egg_base": "build-wheel"}},
    zip_safe=False,
)
