"""Host processes that load pythonfmu FMUs, run so that their results do not depend on how they exit.

pythonfmu 0.7.0's FMU binary has a known exit defect: at interpreter exit its library
destructor can read a freed shared_ptr, and the host aborts ("free(): corrupted unsorted
chunks") after all its work is done, at random (it depends on the memory layout; in one
fresh venv 5 of 6 full-suite runs). A test that read the host's exit status or its last
line of stdout then failed at random.

Here a host script ends with ``finish(result)``: the result is written to a JSON file
(atomically: a temporary file renamed into place, so a half-written file is never read)
and the host leaves with ``os._exit(0)``, after fmpy has called fmi2FreeInstance on every
FMU, skipping the interpreter's finalisation where the defect strikes. `run_host` reads
that file and fails (with the host's stderr) only when the result was not written or the
host reported a failure before it. The exit defect itself is asserted on its own, as a
known defect, in test_fmu_standalone.py (``test_host_exits_cleanly``).
"""
from __future__ import annotations

import json
import subprocess
import sys
import textwrap

# prepended to every host script: ``finish(result)`` writes the result and leaves
PROLOGUE = textwrap.dedent("""
    import json as _json, os as _os, sys as _sys

    def finish(result, _path=_sys.argv[-1]):
        tmp = _path + ".part"
        with open(tmp, "w") as fh:
            _json.dump(result, fh)
            fh.flush()
            _os.fsync(fh.fileno())
        _os.replace(tmp, _path)
        _sys.stdout.flush()
        _sys.stderr.flush()
        _os._exit(0)  # skip finalisation: pythonfmu 0.7.0's exit defect (see tests/host.py)
""")


def run_host(script: str, args, result_path, **kwargs) -> dict:
    """Run ``script`` (which must end with ``finish(result)``) in a fresh Python with
    ``args`` and the result file's path as its last argument; return the result."""
    kwargs.setdefault("capture_output", True)
    kwargs.setdefault("text", True)
    kwargs.setdefault("timeout", 300)
    proc = subprocess.run([sys.executable, "-c", PROLOGUE + textwrap.dedent(script),
                           *map(str, args), str(result_path)], **kwargs)
    try:
        with open(result_path) as fh:
            result = json.load(fh)
    except FileNotFoundError:
        raise AssertionError(f"the host wrote no result (exit status {proc.returncode}):\n"
                             f"{proc.stderr[-3000:]}") from None
    # the result is written just before os._exit(0): a non-zero status after it is impossible
    assert proc.returncode == 0, (proc.returncode, proc.stderr[-3000:])
    return result
