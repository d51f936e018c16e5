"""What the co-simulation master keeps between runs in one process: each FMU's
parsed model description, its extracted files and its loaded library.

A master that runs the same FMUs many times (a sweep, a benchmark, a study) need
not unzip, parse and load them for every run, as FMI tools do not: everything is
keyed by the FMU file's content (SHA-256), so a rebuilt FMU is a new entry and a
stale one is never used. Per process:

* ``model_description(path)``: fmpy's ``read_model_description`` (schema
  validation included) once per content;
* ``extracted(path)``: the FMU unzipped once per content (by fmpy's ``extract``,
  with its checks of the member names) into a private temporary folder, without
  ``sources/`` and ``documentation/``, which running the binary does not need;
  removed at interpreter exit (and, for a process that ended with ``os._exit``
  or was killed, by the next process that uses the cache);
* ``take(path, md, name)`` / ``give_back(path, slave)``: fmpy ``FMU2Slave``
  objects whose library is loaded and whose fmi2 functions are bound, reused for
  new instances. A slave is handed back only after ``fmi2FreeInstance``, so every
  run still instantiates, initialises and frees its own fmi2Component; only the
  ``dlopen`` and fmpy's binding of the functions are saved. (The native FMUs keep
  no state outside their fmi2Component; a pythonfmu library is never unloaded by
  ``dlclose`` anyway.)

A pythonfmu FMU's library puts its ``resources/`` folder first on ``sys.path`` and
imports its slave there; the ``pythonfmu`` package it bundles (without pythonfmu's
binaries) would then become this process's ``pythonfmu``, and a later FMU build in the
same process would package FMUs without binaries. ``extracted`` therefore imports the
installed pythonfmu before such an FMU is loaded, so that the FMU's slave binds to it.

Nothing here changes what a run computes: the same binary, the same calls.
"""
from __future__ import annotations

import atexit
import hashlib
import os
import shutil
import tempfile
import threading
from pathlib import Path

_lock = threading.Lock()
_digests: dict[tuple, str] = {}  # (device, inode, size, mtime) -> SHA-256 of the content
_descriptions: dict[str, object] = {}  # digest -> fmpy ModelDescription
_folders: dict[str, Path] = {}  # digest -> extracted folder
_idle: dict[tuple, list] = {}  # (digest, "cs"/"me") -> FMU2Slave/FMU2Model objects, library loaded, no instance
_root: Path | None = None
_cleanup_registered = False
_ROOT_PARENT = Path(tempfile.gettempdir()) / f"ballmill-fmus-{os.getuid() if hasattr(os, 'getuid') else 'user'}"
_SKIP = ("sources/", "documentation/")  # not needed to run the binary


def digest(path) -> str:
    """SHA-256 of the FMU file's content, computed once per file version (a rewritten
    file has another size, inode or modification time and is hashed again)."""
    st = os.stat(path)
    key = (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns)
    found = _digests.get(key)
    if found is None:
        h = hashlib.sha256()
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
        found = _digests[key] = h.hexdigest()
    return found


def model_description(path):
    """fmpy's parsed (and schema-validated) model description of this FMU, parsed once
    per content. Callers must not modify it."""
    from fmpy import read_model_description

    key = digest(path)
    md = _descriptions.get(key)
    if md is None:
        md = _descriptions[key] = read_model_description(str(path))
    return md


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # exists, owned by someone else
        return True
    return True


def _private_root() -> Path:
    """This process's folder of extracted FMUs (created on first use); folders left by
    processes that no longer run are removed then."""
    global _root, _cleanup_registered
    if _root is None:
        _ROOT_PARENT.mkdir(mode=0o700, exist_ok=True)
        for old in _ROOT_PARENT.glob("pid-*"):
            try:
                pid = int(old.name.split("-")[1])
            except (IndexError, ValueError):
                continue
            if pid != os.getpid() and not _pid_alive(pid):
                shutil.rmtree(old, ignore_errors=True)
        _root = Path(tempfile.mkdtemp(prefix=f"pid-{os.getpid()}-", dir=_ROOT_PARENT))
        if not _cleanup_registered:
            atexit.register(clear)
            _cleanup_registered = True
    return _root


def extracted(path) -> Path:
    """The folder holding this FMU's extracted files (extracted on first use)."""
    from fmpy import extract

    key = digest(path)
    with _lock:
        folder = _folders.get(key)
        if folder is None or not folder.is_dir():
            folder = _private_root() / key[:16]
            shutil.rmtree(folder, ignore_errors=True)
            extract(str(path), folder, include=lambda name: not name.startswith(_SKIP))
            _folders[key] = folder
            if (folder / "resources" / "pythonfmu").is_dir():
                import pythonfmu  # noqa: F401  (the installed one, before the FMU's copy can shadow it)
        return folder


def take(path, md, instance_name: str, interface: str = "cs"):
    """An fmpy FMU2Slave (``interface`` "cs") or FMU2Model ("me") for a new instance of this
    FMU, named ``instance_name``: a reused one (library loaded, functions bound) or a new one.
    Not yet instantiated."""
    from fmpy.fmi2 import FMU2Model, FMU2Slave

    key = (digest(path), interface)
    with _lock:
        pool = _idle.get(key)
        slave = pool.pop() if pool else None
    if slave is None:
        cls, kind = (FMU2Model, md.modelExchange) if interface == "me" else (FMU2Slave, md.coSimulation)
        slave = cls(guid=md.guid, unzipDirectory=str(extracted(path)),
                    modelIdentifier=kind.modelIdentifier, instanceName=instance_name)
    slave.instanceName = instance_name
    slave.component = None
    return slave


def give_back(path, slave, interface: str = "cs") -> None:
    """Return a slave (or model) whose instance has been freed (fmi2FreeInstance), for reuse."""
    slave.component = None
    slave.callbacks = None
    with _lock:
        _idle.setdefault((digest(path), interface), []).append(slave)


def clear() -> None:
    """Forget everything and remove the extracted files (at interpreter exit; tests call
    it to measure a cold start). Libraries stay loaded until the process ends."""
    global _root
    with _lock:
        _digests.clear()
        _descriptions.clear()
        _folders.clear()
        _idle.clear()
        if _root is not None:
            shutil.rmtree(_root, ignore_errors=True)
            _root = None
