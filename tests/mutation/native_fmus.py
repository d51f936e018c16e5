"""Native FMUs for tests that run under mutmut: built once per content of their sources,
outside the tree mutmut copies, and shared by every forked mutant worker.

The scenario runner (ballmill/scenario/runner.py) is the co-simulation master: it runs in
the test process, so mutmut sees its mutants when it drives real FMUs, provided the FMUs do
not have to be built per mutant (tests/conftest.py's `fmu_build_dir` skips under mutmut for
that reason). The native flavour bundles no Python: a native FMU built from the unmutated C
sources is the same file for every mutant of the Python code, so one build serves the whole
run.

* They are built from the checkout, never from mutants/: under mutmut (the tests run in
  ``<checkout>/mutants``) from its parent. mutmut copies the C files into mutants/ once and
  does not refresh them when they change, and its copies of the Python modules are the
  mutated ones; the FMUs must be the unmutated project's.
* The key is a SHA-256 over the content of what a native build reads: the C sources and
  headers of every native model, and the Python files the build's model descriptions and
  generated headers come from (`ballmill/fmi/*.py`: the interface declaration and the native
  builder; `ballmill/physics/**/*.py`: the start values and the Butcher tableaus the
  declaration and the kernel's header read). Only files are read here: no function of a
  mutated module runs in the test process, so the build neither maps tests to mutants in
  mutmut's stats run nor depends on the mutant under test. The ordinary suite and mutmut's
  workers share one build.
* The FMUs live in ``<tmp>/ballmill-native-fmus-<uid>/<key>/`` (never in mutants/, which
  mutmut regenerates, nor in the checkout's build/).
* The build runs in a subprocess of this Python, in the checkout, with MUTANT_UNDER_TEST
  removed from its environment, into a fresh folder that is renamed to the key's folder when every FMU is
  built and validated: a reader never sees half a build. A file lock serialises concurrent
  builders (mutmut's workers, parallel test sessions); the loser finds the folder done.
  It happens once: in mutmut's stats run (MUTANT_UNDER_TEST=stats) or in the first ordinary
  session after a source changed.
"""
from __future__ import annotations

import fcntl
import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parents[2]  # the tree the tests run in (mutants/ under mutmut)
# the checkout: under mutmut the parent of mutants/ (whose copies of the C sources are not
# refreshed when they change, and whose Python is the mutated copy), else this tree
ROOT = HERE.parent if HERE.name == "mutants" and (HERE.parent / "ballmill" / "fmi").is_dir() else HERE
CACHE = Path(tempfile.gettempdir()) / f"ballmill-native-fmus-{os.getuid() if hasattr(os, 'getuid') else 'user'}"
DONE = "complete"  # written last into a finished build folder

_BUILD = """
import sys
from pathlib import Path
out, root, done = Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3]
sys.path.insert(0, str(root))
import ballmill
from ballmill.fmi import build, native
if Path(ballmill.__file__).resolve().parent != root / "ballmill":
    sys.exit(f"imported {ballmill.__file__}, not the checkout's {root}")
for name in native.available():
    build.build_native_one(name, out)
(out / done).write_text("\\n".join(native.available()) + "\\n")
"""


def _python_inputs(root: Path) -> list[Path]:
    pkg = root / "ballmill"
    return sorted(pkg.glob("fmi/*.py")) + sorted((pkg / "physics").rglob("*.py"))


def _c_inputs(root: Path) -> list[Path]:
    """The C files of every native model, read without importing the (possibly mutated)
    package: the plumbing, the models, their headers, the kernel."""
    files = sorted((root / "fmu_src" / "native").glob("*.[ch]"))
    files += sorted((root / "fmu_src").glob("*.c")) + sorted((root / "drive_models").glob("*.[ch]"))
    files += [root / "ballmill" / "physics" / "_kernel.c"]
    return files


def key(root: Path = ROOT) -> str:
    h = hashlib.sha256()
    for f in _c_inputs(root) + _python_inputs(root):
        h.update(f.relative_to(root).as_posix().encode() + b"\0")
        h.update(f.read_bytes())
        h.update(b"\0")
    return h.hexdigest()[:24]


def built(folder: Path) -> dict[str, Path]:
    """model name -> FMU path of a finished build folder."""
    names = (folder / DONE).read_text().split()
    return {name: folder / f"{name}.fmu" for name in names}


def native_fmus(root: Path = ROOT) -> dict[str, Path]:
    """model name -> native FMU path, built now if this content was never built."""
    target = CACHE / key(root)
    if (target / DONE).is_file():
        return built(target)
    CACHE.mkdir(parents=True, exist_ok=True)
    with open(CACHE / f"{target.name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not (target / DONE).is_file():  # nobody built it while we waited
            env = {k: v for k, v in os.environ.items() if k != "MUTANT_UNDER_TEST"}
            fresh = Path(tempfile.mkdtemp(prefix=f"{target.name}.", dir=CACHE))
            proc = subprocess.run([sys.executable, "-c", _BUILD, str(fresh), str(root), DONE],
                                  cwd=root, env=env, capture_output=True, text=True)
            if proc.returncode != 0 or not (fresh / DONE).is_file():
                shutil.rmtree(fresh, ignore_errors=True)
                raise RuntimeError(f"building the native FMUs in {root} failed (exit {proc.returncode}):\n"
                                   f"{proc.stdout}\n{proc.stderr}")
            if target.exists():  # a partial folder of an older layout: replace it
                shutil.rmtree(target)
            fresh.rename(target)
    return built(target)
