"""Build every FMU of the project, in both flavours, and validate it.

* native (`ballmill.fmi.native`): C, only libc/libm, at ``build/<Model>.fmu`` -
  what `ballmill run`, SSP export, libcosim and other tools use by default;
* pythonfmu: the Python reference at ``build/pythonfmu/<Model>.fmu``.

Both come from the one declaration of each interface (ballmill/fmi/interface.py).
Without a C compiler (or for a model without a C file) the native path gets a copy
of the pythonfmu FMU, and the build says so.

The pythonfmu adapter scripts are the ``*_fmu.py`` files in fmu_src/ (the ball) and
drive_models/ (drives). Each FMU bundles the parts of this package it needs
(``ballmill.physics`` and ``ballmill.fmi.slave``) in its resources, so a
built FMU needs only numpy and scipy from the importing Python, not an
installed ballmill.

The bundle includes the compiled kernel as it is built here (the
``_kernel*`` extension beside ``ballmill/physics/fast.py``), provided it is
the build of the ``_kernel.c`` beside it (checked here, with fast.py's checks;
the source itself stays out of the bundle, so that the FMU's fast.py skips
that check and its hashing at load time): BallInShell's ``BallModel.advance``
then integrates in C. Where that library cannot be used (another OS,
architecture, Python or C library, a damaged file), the FMU's fast.py says
why and the FMU runs in pure Python with the same results.
"""
from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import ballmill

from . import native

PACKAGE_DIR = Path(ballmill.__file__).resolve().parent
ROOT = PACKAGE_DIR.parent
SOURCE_DIRS = ("fmu_src", "drive_models")
BUNDLED = ("__init__.py", "physics", "fmi/__init__.py", "fmi/interface.py", "fmi/slave.py",
           "absorber/__init__.py", "absorber/structure.py")


class BuildError(RuntimeError):
    """An FMU could not be built, or its model description has problems."""


def scripts(root: Path = ROOT) -> list[Path]:
    """The FMU adapter scripts, sorted."""
    found = []
    for d in SOURCE_DIRS:
        found += sorted((root / d).glob("*_fmu.py"))
    if not found:
        raise BuildError(f"no *_fmu.py scripts found in {', '.join(SOURCE_DIRS)} under {root}; "
                         f"ballmill build needs a checkout of the repository (pip install -e .)")
    return found


def model_name(script: Path) -> str:
    """The model identifier of a script: its Slave subclass's name, read from the source."""
    for line in script.read_text().splitlines():
        if line.startswith("class ") and "(Slave)" in line:
            return line.split()[1].split("(")[0]
    raise BuildError(f"{script}: no 'class X(Slave)' found")


# the compiled kernel's source and builds (their changes make a bundle out of date)
KERNEL_FILES = ("_kernel.c", "_kernel.*.so", "_kernel.*.pyd", "_kernel.so", "_kernel.pyd", "_kernel.dylib")


def _kernel_files(directory: Path) -> list[Path]:
    return sorted({f for pattern in KERNEL_FILES for f in directory.glob(pattern) if f.is_file()})


def _sources(script: Path) -> list[Path]:
    files = [script]
    for item in BUNDLED:
        p = PACKAGE_DIR / item
        files += (list(p.rglob("*.py")) + _kernel_files(p)) if p.is_dir() else [p]
    return files


def kernel_to_bundle() -> tuple[Path | None, str]:
    """(the compiled kernel library to bundle, '') or (None, why none)."""
    from ballmill.physics import fast

    path = fast._find_library()
    if path is None:
        return None, "no compiled kernel built (pip install -e . with a C compiler)"
    why = fast.check_library(path)
    return (None, why) if why else (path, "")


FLAVOURS = ("native", "pythonfmu")


def _check_flavour(flavour: str) -> None:
    if flavour not in FLAVOURS:
        raise BuildError(f"FMU flavour must be one of {FLAVOURS}, got {flavour!r}")


def fmu_path(name: str, build_dir: Path | None = None, flavour: str = "native") -> Path:
    """build/<name>.fmu (native) or build/pythonfmu/<name>.fmu."""
    _check_flavour(flavour)
    base = Path(build_dir or ROOT / "build")
    return (base if flavour == "native" else base / "pythonfmu") / f"{name}.fmu"


def up_to_date(script: Path, build_dir: Path | None = None, flavour: str = "pythonfmu") -> bool:
    name = model_name(script)
    target = fmu_path(name, build_dir, flavour)
    if not target.exists():
        return False
    built = target.stat().st_mtime
    newest = max(src.stat().st_mtime for src in _sources(script))
    if flavour == "native" and name in native.available():
        if native.has_compiler() and not native.is_native(target):
            return False  # a pythonfmu copy from a build without a compiler
        newest = native.newest_source_mtime(name)
    return newest <= built


def _stage(dest: Path) -> tuple[Path, str]:
    """Copy the bundled part of the package into dest/ballmill, with the compiled
    kernel if it passes `kernel_to_bundle`. Returns (package folder, why no kernel or '')."""
    pkg = dest / "ballmill"
    for item in BUNDLED:
        src = PACKAGE_DIR / item
        target = pkg / item
        target.parent.mkdir(parents=True, exist_ok=True)
        if src.is_dir():
            shutil.copytree(src, target, ignore=shutil.ignore_patterns(
                "__pycache__", "*.so", "*.pyd", "*.dylib", "*.c", "*.o"))
        else:
            shutil.copy2(src, target)
    lib, why = kernel_to_bundle()
    if lib is not None:
        shutil.copy2(lib, pkg / "physics" / lib.name)
    return pkg, why


def validate(fmu: Path) -> list[str]:
    """fmpy's validation problems for an FMU (empty list: valid)."""
    from fmpy.validation import validate_fmu
    return list(validate_fmu(str(fmu)))


def _validated(fmu: Path) -> Path:
    problems = validate(fmu)
    if problems:
        raise BuildError(f"{fmu}: the model description has {len(problems)} problem(s):\n  - "
                         + "\n  - ".join(problems))
    return fmu


def build_native_one(name: str, build_dir: Path | None = None) -> Path:
    """Build and validate the native FMU of model `name`."""
    try:
        return _validated(native.build_native(name, Path(build_dir or ROOT / "build")))
    except native.NativeBuildError as e:
        raise BuildError(str(e)) from None


def build_one(script: Path, build_dir: Path | None = None) -> Path:
    """Build and validate one pythonfmu FMU (into build_dir/pythonfmu/); raise BuildError
    listing the problems."""
    from pythonfmu.builder import FmuBuilder

    out_dir = fmu_path(model_name(script), build_dir, "pythonfmu").parent
    out_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="ballmill_stage_") as tmp:
        pkg, _ = _stage(Path(tmp))
        fmu = FmuBuilder.build_FMU(script, dest=out_dir, project_files=[pkg],
                                   canGetAndSetFMUstate=True, canSerializeFMUstate=True)
    return _validated(Path(fmu))


def build_all(build_dir: Path | None = None, force: bool = False, log=print,
              flavour: str = "native") -> list[Path]:
    """Build both flavours of every FMU that is missing or older than its sources;
    return the paths of `flavour`'s FMUs."""
    _check_flavour(flavour)
    paths = {f: [] for f in FLAVOURS}
    for script in scripts():
        name = model_name(script)
        py = fmu_path(name, build_dir, "pythonfmu")
        if force or not up_to_date(script, build_dir, "pythonfmu"):
            build_one(script, build_dir)
            why = kernel_to_bundle()[1]
            log(f"built and validated: {py}" + (f" (without the compiled kernel: {why})" if why else ""))
        else:
            log(f"up to date: {py}")
        paths["pythonfmu"].append(py)
        nat = fmu_path(name, build_dir, "native")
        if not force and up_to_date(script, build_dir, "native"):
            log(f"up to date: {nat}")
        elif name in native.available() and native.has_compiler():
            build_native_one(name, build_dir)
            log(f"built and validated: {nat} (native)")
        else:
            shutil.copy2(py, nat)
            why = "no native model" if name not in native.available() else \
                "no C compiler (cc, gcc, clang or $CC) to build the native FMU"
            log(f"{why} for {name}: {nat} is a copy of the pythonfmu flavour")
        paths["native"].append(nat)
    return paths[flavour]
