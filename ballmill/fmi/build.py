"""Build every FMU of the project into build/ and validate it.

The adapter scripts are the ``*_fmu.py`` files in fmu_src/ (the ball) and
drive_models/ (drives). Each FMU bundles the parts of this package it needs
(``ballmill.physics`` and ``ballmill.fmi.slave``) in its resources, so a
built FMU needs only numpy and scipy from the importing Python, not an
installed ballmill.
"""
from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import ballmill

PACKAGE_DIR = Path(ballmill.__file__).resolve().parent
ROOT = PACKAGE_DIR.parent
SOURCE_DIRS = ("fmu_src", "drive_models")
BUNDLED = ("__init__.py", "physics", "fmi/__init__.py", "fmi/slave.py")


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


def _sources(script: Path) -> list[Path]:
    files = [script]
    for item in BUNDLED:
        p = PACKAGE_DIR / item
        files += list(p.rglob("*.py")) if p.is_dir() else [p]
    return files


def fmu_path(name: str, build_dir: Path | None = None) -> Path:
    return Path(build_dir or ROOT / "build") / f"{name}.fmu"


def up_to_date(script: Path, build_dir: Path | None = None) -> bool:
    target = fmu_path(model_name(script), build_dir)
    if not target.exists():
        return False
    built = target.stat().st_mtime
    return all(src.stat().st_mtime <= built for src in _sources(script))


def _stage(dest: Path) -> Path:
    """Copy the bundled part of the package into dest/ballmill."""
    pkg = dest / "ballmill"
    for item in BUNDLED:
        src = PACKAGE_DIR / item
        target = pkg / item
        target.parent.mkdir(parents=True, exist_ok=True)
        if src.is_dir():
            # the compiled kernel (and its source) serve monolithic runs only: FMUs stay pure Python
            shutil.copytree(src, target, ignore=shutil.ignore_patterns(
                "__pycache__", "*.so", "*.pyd", "*.dylib", "*.c"))
        else:
            shutil.copy2(src, target)
    return pkg


def validate(fmu: Path) -> list[str]:
    """fmpy's validation problems for an FMU (empty list: valid)."""
    from fmpy.validation import validate_fmu
    return list(validate_fmu(str(fmu)))


def build_one(script: Path, build_dir: Path | None = None) -> Path:
    """Build and validate one FMU; raise BuildError listing the problems."""
    from pythonfmu.builder import FmuBuilder

    out_dir = Path(build_dir or ROOT / "build")
    out_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="ballmill_stage_") as tmp:
        pkg = _stage(Path(tmp))
        fmu = FmuBuilder.build_FMU(script, dest=out_dir, project_files=[pkg],
                                   canGetAndSetFMUstate=True, canSerializeFMUstate=True)
    problems = validate(Path(fmu))
    if problems:
        raise BuildError(f"{fmu}: the model description has {len(problems)} problem(s):\n  - "
                         + "\n  - ".join(problems))
    return Path(fmu)


def build_all(build_dir: Path | None = None, force: bool = False, log=print) -> list[Path]:
    """Build every FMU that is missing or older than its sources."""
    built = []
    for script in scripts():
        if not force and up_to_date(script, build_dir):
            log(f"up to date: {fmu_path(model_name(script), build_dir)}")
            built.append(fmu_path(model_name(script), build_dir))
            continue
        fmu = build_one(script, build_dir)
        log(f"built and validated: {fmu}")
        built.append(fmu)
    return built
