"""Builds the optional compiled kernel of ballmill.physics (all metadata is in pyproject.toml).

ballmill/physics/_kernel.c becomes the extension module ballmill.physics._kernel,
which ballmill.physics.fast loads with ctypes. ``optional=True``: without a
working C compiler the install still succeeds and the library runs in Python.
The build embeds the first 60 bits of the source's sha256, so that fast.py can
refuse a build that is older than the _kernel.c beside it.
"""
import hashlib
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

SOURCE = "ballmill/physics/_kernel.c"


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


digest = hashlib.sha256((Path(__file__).parent / SOURCE).read_bytes()).hexdigest()[:15]
kernel = Extension(
    "ballmill.physics._kernel",
    sources=[SOURCE],
    define_macros=[("BALLMILL_KERNEL_MODULE", "1"), ("BM_SOURCE_HASH", f"0x{digest}ULL")],
    optional=True,
)

setup(ext_modules=[kernel], cmdclass={"build_ext": BuildKernel})
