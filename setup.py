"""Builds the optional compiled kernel of ballmill.physics (all metadata is in pyproject.toml).

ballmill/physics/_kernel.c becomes the extension module ballmill.physics._kernel,
which ballmill.physics.fast loads with ctypes. ``optional=True``: without a
working C compiler the install still succeeds and the library runs in Python.
The build embeds the first 60 bits of the sources' sha256 (_kernel.c and the crank_law.h it
includes), so that fast.py can refuse a build that is older than the sources beside it.
"""
import hashlib
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

SOURCE = "ballmill/physics/_kernel.c"
HEADERS = ["ballmill/physics/crank_law.h"]  # #included by _kernel.c (fast.KERNEL_HEADERS)


class BuildKernel(build_ext):
    """No fused multiply-adds: the kernel must round like the Python code it mirrors."""

    def build_extensions(self):
        if self.compiler.compiler_type == "msvc":
            flags = ["/fp:precise"]
        else:  # gcc, clang
            flags = ["-ffp-contract=off", "-fno-fast-math", "-g0"]
        for ext in self.extensions:
            ext.extra_compile_args = list(ext.extra_compile_args or []) + flags
        super().build_extensions()


here = Path(__file__).parent
digest = hashlib.sha256(b"".join((here / f).read_bytes() for f in [SOURCE, *HEADERS])).hexdigest()[:15]
kernel = Extension(
    "ballmill.physics._kernel",
    sources=[SOURCE],
    depends=HEADERS,
    define_macros=[("BALLMILL_KERNEL_MODULE", "1"), ("BM_SOURCE_HASH", f"0x{digest}ULL")],
    optional=True,
)

setup(ext_modules=[kernel], cmdclass={"build_ext": BuildKernel})
