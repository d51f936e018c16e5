"""Build every FMU of the project, in both flavours, and validate it.

* native (`ballmill.fmi.native`): C, only libc/libm, at ``build/<Model>.fmu`` -
  what `ballmill run`, SSP export, libcosim and other tools use by default;
* pythonfmu: the Python reference at ``build/pythonfmu/<Model>.fmu``;
* beside each native FMU, the FMI cross-check files of its default experiment in
  ``build/crosscheck/<Model>/`` (`ballmill.fmi.crosscheck`), produced by a run of that FMU.

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

import hashlib
import json
import math
import os
import shutil
import tempfile
import time
from pathlib import Path

import ballmill

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
KERNEL_FILES = ("_kernel.c", "crank_law.h", "_kernel.*.so", "_kernel.*.pyd", "_kernel.so", "_kernel.pyd", "_kernel.dylib")


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
    """Whether the FMU of `script` is newer than every file it is built from (the rule for a
    build folder without a stamp: `build_all` decides by content where it has one)."""
    from . import native

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
                "__pycache__", "*.so", "*.pyd", "*.dylib", "*.c", "*.h", "*.o"))
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
    from . import native

    try:
        return _validated(native.build_native(name, Path(build_dir or ROOT / "build")))
    except native.NativeBuildError as e:
        raise BuildError(str(e)) from None


def build_one(script: Path, build_dir: Path | None = None) -> Path:
    """Build and validate one pythonfmu FMU (into build_dir/pythonfmu/); raise BuildError
    listing the problems."""
    import pythonfmu
    from pythonfmu.builder import FmuBuilder

    binaries = Path(pythonfmu.__file__).parent / "resources" / "binaries"
    if not binaries.is_dir():  # e.g. the copy a pythonfmu FMU run in this process put on sys.path
        raise BuildError(f"cannot build {script.name}: the pythonfmu package imported from "
                         f"{Path(pythonfmu.__file__).parent} has no resources/binaries (expected the "
                         "installed pythonfmu); build in a fresh process")
    target = fmu_path(model_name(script), build_dir, "pythonfmu")
    target.parent.mkdir(parents=True, exist_ok=True)
    # pythonfmu writes the archive in place: built in a folder of its own beside the target and
    # renamed into place, so that a reader (or a second build) never sees a half-written FMU
    with tempfile.TemporaryDirectory(prefix="ballmill_stage_") as tmp, \
            tempfile.TemporaryDirectory(prefix=".partial_", dir=target.parent) as part:
        pkg, _ = _stage(Path(tmp))
        fmu = FmuBuilder.build_FMU(script, dest=part, project_files=[pkg],
                                   canGetAndSetFMUstate=True, canSerializeFMUstate=True)
        Path(fmu).replace(target)
    return _validated(target)


# ----------------------------------------------------------------------------- the build's stamp
# build_dir/STAMP records, for every FMU built there, the content (SHA-256) of each file it was
# built from, and for each of those files the size and modification time at which that hash was
# taken; with the modification times of the folders whose listing decides what the sources are.
# When every one of those stats is unchanged and every hash is the one its FMU was built from,
# the build is up to date: one JSON read and a few dozen stat calls, without importing anything.
# Otherwise the full check hashes what changed, and rebuilds only the FMUs whose sources' content
# changed (a checkout that only touched modification times rebuilds nothing).
STAMP = ".ballmill-build.json"
STAMP_FORMAT = 1
# what building an FMU costs, for the estimate the build announces: the compiler's CPU seconds
# per native model (at -O2; BallInShell and InductionMotor #include the kernel), measured on a
# 2-core x86-64 machine, and packaging a pythonfmu FMU
NATIVE_S = {"BallInShell": 2.6, "InductionMotor": 1.8}
NATIVE_OTHER_S, PYTHONFMU_S = 0.8, 0.4


def _stat(path) -> list:
    st = os.stat(path)
    return [st.st_mtime_ns, st.st_size]


def _source_dirs() -> list[Path]:
    """The folders whose listing decides the sources: the adapter scripts' and the bundled packages'."""
    dirs = [ROOT / d for d in SOURCE_DIRS]
    for item in BUNDLED:
        p = PACKAGE_DIR / item
        if p.is_dir():
            dirs += [p] + sorted(d for d in p.rglob("*") if d.is_dir() and d.name != "__pycache__")
    return dirs


def _read_stamp(base: Path) -> dict:
    try:
        stamp = json.loads((base / STAMP).read_text())
    except (OSError, ValueError):
        return {}
    return stamp if isinstance(stamp, dict) and stamp.get("format") == STAMP_FORMAT else {}


def _fresh(base: Path, wanted, names) -> dict | None:
    """{flavour: FMU paths} when the stamp shows every FMU of the wanted flavours up to date,
    else None (the full check decides). A native FMU that is a copy of the pythonfmu one (no C
    compiler when it was built) always goes to the full check, which looks for a compiler."""
    stamp = _read_stamp(base)
    if not stamp:
        return None
    files, known = stamp["files"], {}

    def unchanged(path: str) -> bool:
        ok = known.get(path)
        if ok is None:
            rec = files.get(path)
            ok = known[path] = rec is not None and rec[:2] == _stat(path)
        return ok
    try:
        if any(os.stat(d).st_mtime_ns != m for d, m in stamp["dirs"].items()):
            return None
        if not all(unchanged(s) for s in stamp["scripts"]):
            return None
        out = {}
        for flavour in wanted:
            out[flavour] = []
            for name in stamp["scripts"].values():
                if names is not None and name not in names:
                    continue
                entry = stamp["fmus"].get(f"{flavour}/{name}")
                path = fmu_path(name, base, flavour)
                if entry is None or entry["copy"] or entry["stat"] != _stat(path):
                    return None
                if not all(unchanged(src) and files[src][2] == sha for src, sha in entry["sources"].items()):
                    return None
                if flavour == "native":  # its cross-check files (ballmill.fmi.crosscheck), by stat
                    cc = entry["crosscheck"]
                    if not (unchanged(cc["generator"][0]) and files[cc["generator"][0]][2] == cc["generator"][1]
                            and all(_stat(f) == st for f, st in cc["files"].items())):
                        return None
                out[flavour].append(path)
    except (OSError, KeyError, TypeError, IndexError):
        return None
    return out


def _crosscheck_fresh(entry, generator: str, sha) -> bool:
    """Whether a native FMU's stamp entry records cross-check files that are still there as
    written, by this generator."""
    cc = (entry or {}).get("crosscheck")
    try:
        return (cc["generator"] == [generator, sha(generator)]
                and all(_stat(f) == st for f, st in cc["files"].items()))
    except (OSError, KeyError, TypeError):
        return False


def _sha256(path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _workers() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def build_all(build_dir: Path | None = None, force: bool = False, log=print,
              flavour: str = "native", only: bool = False, names=None) -> list[Path]:
    """Build every FMU that is missing or whose sources changed, in both flavours (``only``:
    just what ``flavour`` needs: its FMUs, and the pythonfmu ones a native copy is made of;
    ``names``: only these models, names of no model ignored), validate each; return the paths
    of ``flavour``'s FMUs. When something is built, ``log`` gets a line announcing how many
    FMUs and about how long, then one line per FMU; an up to date build logs nothing
    (``log=None``: never anything)."""
    _check_flavour(flavour)
    base = Path(build_dir or ROOT / "build")
    wanted = (flavour,) if only else FLAVOURS
    names = None if names is None else set(names)
    if not force:
        fresh = _fresh(base, wanted, names)
        if fresh is not None:
            return fresh[flavour]
    return _build(base, wanted, force, log or (lambda message: None), names)[flavour]


def model_names() -> list[str]:
    """Every model the project builds, in the order of its adapter scripts."""
    return [model_name(s) for s in scripts()]


def _build(base: Path, wanted, force: bool, log, names=None) -> dict:
    """The full check and the build of what it finds out of date; writes the stamp."""
    from concurrent.futures import ThreadPoolExecutor

    from . import crosscheck, native

    dirs = {str(d): os.stat(d).st_mtime_ns for d in _source_dirs()}  # before listing them
    old = _read_stamp(base)
    old_files, old_fmus = old.get("files", {}), old.get("fmus", {})
    files: dict[str, list] = {}

    def sha(path: str) -> str:
        rec = files.get(path)
        if rec is None:
            now, prev = _stat(path), old_files.get(path)
            rec = files[path] = now + [prev[2] if prev and prev[:2] == now else _sha256(path)]
        return rec[2]

    all_scripts = {model_name(s): s for s in scripts()}
    script_of = {n: s for n, s in all_scripts.items() if names is None or n in names}
    compiled = native.has_compiler()
    real_native = {n for n in script_of if n in native.available() and compiled}
    need = {(fl, n) for fl in wanted for n in script_of}
    need |= {("pythonfmu", n) for fl, n in need if fl == "native" and n not in real_native}

    def sources(fl: str, name: str) -> list[str]:
        srcs = native.build_inputs(name) if fl == "native" and name in real_native else _sources(script_of[name])
        return sorted({str(p) for p in srcs})

    def stale(fl: str, name: str, srcs: list[str]) -> bool:
        target = fmu_path(name, base, fl)
        if force or not target.exists():
            return True
        entry = old_fmus.get(f"{fl}/{name}")
        if entry is None or entry.get("stat") != _stat(target):
            # built before this folder had a stamp, or since by someone else: the times decide
            return not up_to_date(script_of[name], base, fl)
        if fl == "native" and entry.get("copy") and name in real_native:
            return True  # a copy of the pythonfmu flavour, and now there is a compiler
        return sorted(entry.get("sources", {})) != srcs or any(sha(p) != h for p, h in entry["sources"].items())

    order = [(fl, n) for fl in ("pythonfmu", "native") for n in script_of if (fl, n) in need]
    srcs = {key: sources(*key) for key in order}
    built_from = {key: {p: sha(p) for p in srcs[key]} for key in order}  # hashed before building
    todo = [key for key in order if stale(key[0], key[1], srcs[key])]
    # a native copy follows its pythonfmu FMU
    todo += [("native", n) for fl, n in todo if fl == "pythonfmu" and ("native", n) in need
             and n not in real_native and ("native", n) not in todo]
    fmus = {k: v for k, v in old_fmus.items() if tuple(k.split("/", 1)) not in need}
    if todo:
        workers = _workers()
        costs = [NATIVE_S.get(n, NATIVE_OTHER_S) for fl, n in todo if fl == "native" and n in real_native]
        # in parallel, one per core: at least the longest, at least an even share of the total
        estimate = (max(max(costs, default=0.0), sum(costs) / workers)
                    + (len(todo) - len(costs)) * PYTHONFMU_S)
        missing = sum(not fmu_path(n, base, fl).exists() for fl, n in todo)
        if force:
            why = "--force"
        elif not any(fmu_path(n, base, fl).exists() for fl, n in need):
            why = "first build"
        else:
            why = ", ".join(f"{count} {text}" for count, text in ((missing, "not built yet"),
                                                                  (len(todo) - missing, "with changed sources"))
                            if count)
        log(f"building {len(todo)} FMU{'s' if len(todo) != 1 else ''} in {base} ({why}; about "
            f"{max(1, math.ceil(estimate))} s on {workers} free core{'s' if workers != 1 else ''})...")
        t_start, done = time.perf_counter(), [0]

        def report(path: Path, seconds: float, note: str = ""):
            done[0] += 1
            log(f"  [{done[0]}/{len(todo)}] {path}: built and validated in {seconds:.1f} s{note}")

        for fl, name in todo:
            if fl == "pythonfmu":
                t0 = time.perf_counter()
                path = build_one(script_of[name], base)
                why_not = kernel_to_bundle()[1]
                report(path, time.perf_counter() - t0, f" (without the compiled kernel: {why_not})" if why_not else "")

        def compile_one(name: str):
            t0 = time.perf_counter()
            try:  # the FMI 3.0 archive with it, from the same sources (build/fmi3/)
                _validated(native.build_native(name, base / "fmi3", fmi=3))
                return native.build_native(name, base), time.perf_counter() - t0
            except native.NativeBuildError as e:
                raise BuildError(str(e)) from None
        natives = [n for fl, n in todo if fl == "native" and n in real_native]
        with ThreadPoolExecutor(max_workers=min(workers, max(len(natives), 1))) as pool:
            futures = [pool.submit(compile_one, n) for n in natives]
            for future in futures:  # validated in this thread, in order
                path, seconds = future.result()
                t0 = time.perf_counter()
                report(_validated(path), seconds + time.perf_counter() - t0, " (native)")
        for fl, name in todo:
            if fl == "native" and name not in real_native:
                py, nat = fmu_path(name, base, "pythonfmu"), fmu_path(name, base, "native")
                shutil.copy2(py, nat)
                why_not = "no native model" if name not in native.available() else \
                    "no C compiler (cc, gcc, clang or $CC) to build the native FMU"
                report(nat, 0.0, f" ({why_not}: a copy of the pythonfmu flavour)")
        log(f"built {len(todo)} FMU{'s' if len(todo) != 1 else ''} in {time.perf_counter() - t_start:.1f} s")
    # the cross-check files of each real native FMU: rewritten with its FMU, or when missing,
    # touched or built by another version of their generator
    generator = str(crosscheck.GENERATOR)
    stale_cc = [n for fl, n in order if fl == "native" and n in real_native
                and (("native", n) in todo or not _crosscheck_fresh(old_fmus.get(f"native/{n}"), generator, sha))]
    written = {}
    if stale_cc:
        t0 = time.perf_counter()
        for name in stale_cc:
            try:
                written[name] = crosscheck.write(name, fmu_path(name, base), base)
            except crosscheck.CrossCheckError as e:
                raise BuildError(str(e)) from None
        log(f"wrote the FMI cross-check files of {len(stale_cc)} FMU{'s' if len(stale_cc) != 1 else ''} in "
            f"{crosscheck.folder('', base)} in {time.perf_counter() - t0:.1f} s")
    for fl, name in order:
        entry = fmus[f"{fl}/{name}"] = {"stat": _stat(fmu_path(name, base, fl)),
                                        "copy": fl == "native" and name not in real_native,
                                        "sources": built_from[(fl, name)]}
        if fl == "native" and name in real_native:
            paths = written.get(name) or crosscheck.files(name, base)
            entry["crosscheck"] = {"generator": [generator, sha(generator)],
                                   "files": {str(f): _stat(f) for f in paths}}
    for script in all_scripts.values():
        sha(str(script))
    stamp = {"format": STAMP_FORMAT, "dirs": dirs, "scripts": {str(s): n for n, s in all_scripts.items()},
             "fmus": fmus, "files": {**{p: r for p, r in old_files.items() if p not in files}, **files}}
    tmp = base / f"{STAMP}.{os.getpid()}.part"
    base.mkdir(parents=True, exist_ok=True)
    tmp.write_text(json.dumps(stamp, indent=0))
    tmp.replace(base / STAMP)
    return {fl: [fmu_path(n, base, fl) for n in script_of] for fl in wanted}
