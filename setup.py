"""pip install from the checkout: the binding `spacearm` built by the project's CMake.

    python3 -m venv --system-site-packages venv     # Debian's numpy (and dask) in the venv
    venv/bin/pip install --no-build-isolation .     # offline: Debian's setuptools, no download

SPACEARM_BUILD_DIR=build reuses a configured CMake build folder (the README's set-up) instead
of configuring a new one in build-pip/cmake; JOBS sets the parallel build jobs (default 2).
"""
import glob
import os
import re
import shutil
import subprocess
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = os.path.dirname(os.path.abspath(__file__))


def version():
    """The generator's version, from the one place that names it."""
    text = open(os.path.join(ROOT, "generator", "version.hpp")).read()
    return re.search(r'kGeneratorVersion = "([^"]+)"', text).group(1)


class CMakeBuild(build_ext):
    """Builds the _spacearm target with CMake and copies the module where setuptools wants it."""

    def build_extension(self, ext):
        folder = os.environ.get("SPACEARM_BUILD_DIR") or os.path.join(ROOT, "build-pip", "cmake")
        folder = os.path.abspath(folder)
        if not os.path.isfile(os.path.join(folder, "CMakeCache.txt")):
            subprocess.run(["cmake", "-S", ROOT, "-B", folder, "-G", "Ninja",
                            "-DCMAKE_BUILD_TYPE=Release", "-DSPACEARM_BUILD_TESTS=OFF",
                            "-DPython_EXECUTABLE=" + sys.executable], check=True)
        subprocess.run(["cmake", "--build", folder, "--target", "_spacearm", "-j",
                        os.environ.get("JOBS", "2")], check=True)
        built = glob.glob(os.path.join(folder, "python", "spacearm", "_spacearm*.so"))
        if len(built) != 1:
            sys.exit("setup.py: expected one _spacearm module in %s/python/spacearm, found %s"
                     % (folder, built))
        target = self.get_ext_fullpath(ext.name)
        os.makedirs(os.path.dirname(target), exist_ok=True)
        shutil.copyfile(built[0], target)


setup(
    name="spacearm",
    version=version(),
    description="Exact, inspectable and fast dynamics of free-floating space manipulators, planar and spatial",
    packages=["spacearm"],
    package_dir={"": "python"},
    ext_modules=[Extension("spacearm._spacearm", sources=[])],
    cmdclass={"build_ext": CMakeBuild},
    python_requires=">=3.9",
    install_requires=["numpy"],
    extras_require={"dask": ["distributed"]},
)
