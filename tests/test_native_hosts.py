"""The native FMUs in a real host: a small C program (tests/hosts/fmi_host.c) compiled
here, which dlopens each FMU's binary without Python and without LD_PRELOAD (FMI 2.0, and
FMI 3.0 co-simulation with event mode and early return: the same host built with
-DFMI_VERSION=3).

* each native binary needs nothing but libc and libm (readelf -d);
* 100 runs of the host per FMU: 0 crashes, every run the same (physically checked) value;
* valgrind: no invalid read or write, no definitely lost block (FMI 2.0, also with the hybrid ball;
  FMI 3.0 through an early return and event mode; Model Exchange, tests/hosts/me_host.c);
* AddressSanitizer and UndefinedBehaviorSanitizer: each model's sources compiled with them
  (what valgrind cannot see: a write past a local array, an index out of an array's bounds,
  signed overflow, a leak at exit) run in the host compiled with them, and find nothing;
* 1000 instantiate/run/free cycles in one process grow its RSS by less than 1 MB;
* fmpy builds a working platform binary from the sources the FMU carries.
"""
from __future__ import annotations

import math
import re
import shutil
import subprocess
import zipfile
from pathlib import Path

import pytest
from fmpy import read_model_description

from ballmill.fmi import native
from ballmill.physics import Ball

HOST = Path(__file__).parent / "hosts" / "fmi_host.c"
pytestmark = pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler (cc)")

# model -> (output checked, steps of 2 ms, expected value of the output after them)
_ball = Ball()
_t = 50 * 0.002
_w0 = 2.0 * math.pi * 60.0 / 60.0
CASES = {
    # the chamber at rest (inputs 0): the ball rests at the bottom, N = m g exactly
    "BallInShell": ("N", 50, _ball.m * _ball.g),
    # the start-up law: psi' = w0 (1 - (1 - t/t0)^2) at t = 0.1 s, t0 = 2.5 s
    "MotorStartup": ("psi_dot", 50, _w0 * (1.0 - (1.0 - _t / 2.5) ** 2)),
    # the motor started direct on line, unloaded: the pythonfmu reference's crank speed
    "InductionMotor": ("psi_dot", 50, None),
    # at rest by default (no excitation): the load on the binary, its memory and its carried
    # sources are what is checked here; the instantaneous excitation frequency is f_exc
    "Structure": ("f_inst", 50, 0.8),
    # the Fig. 1 machine (defaults): z1O = sin(phi) l sin(psi), phi = 0.5 rad/s t, psi the paper's law
    "Fig1Drive": ("z1O", 50, math.sin(0.5 * _t) * 0.5 * math.sin(
        -_w0 * (_t - 2.5) ** 3 / (3.0 * 2.5 ** 2) + _w0 * _t - _w0 * 2.5 / 3.0)),
}


def _expected(model, fmus_of):
    name, steps, value = CASES[model]
    if value is not None:
        return value
    from fmpy import simulate_fmu
    res = simulate_fmu(str(fmus_of("pythonfmu")[model]), stop_time=steps * 0.002, step_size=0.002,
                       output_interval=0.002)
    return float(res[name][-1])


def _compile(tmp_path_factory, fmi: int) -> Path:
    exe = tmp_path_factory.mktemp("host") / f"fmi{fmi}_host"
    proc = subprocess.run(["cc", "-O2", "-Wall", "-Wextra", "-Werror", f"-DFMI_VERSION={fmi}", "-I",
                           str(native.fmi_headers_dir()), str(HOST), "-o", str(exe), "-ldl"],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return exe


@pytest.fixture(scope="module")
def host(tmp_path_factory) -> Path:
    return _compile(tmp_path_factory, 2)


@pytest.fixture(scope="module")
def host3(tmp_path_factory) -> Path:
    return _compile(tmp_path_factory, 3)


@pytest.fixture(scope="module")
def unpacked(fmus_of, tmp_path_factory):
    """model -> (binary, guid, value reference of its checked output)."""
    out = {}
    for model, path in fmus_of("native").items():
        md = read_model_description(str(path))
        if model not in CASES:
            continue
        d = tmp_path_factory.mktemp(model)
        zipfile.ZipFile(path).extractall(d)
        vr = {v.name: v.valueReference for v in md.modelVariables}[CASES[model][0]]
        out[model] = (d / "binaries" / native.platform_dir() / f"{model}{native.shared_suffix()}", md.guid, vr)
    return out


VALGRIND = ("valgrind", "--error-exitcode=99", "--leak-check=full", "--errors-for-leak-kinds=definite")


def _assert_valgrind_clean(proc):
    """The host under VALGRIND left with status 0, valgrind found no error and no definitely lost block."""
    assert proc.returncode == 0, proc.stdout + proc.stderr[-3000:]
    assert "ERROR SUMMARY: 0 errors" in proc.stderr
    lost = re.search(r"definitely lost: ([\d,]+) bytes", proc.stderr)
    assert lost is None or lost.group(1) == "0", proc.stderr[-2000:]


def _run(host, binary, guid, vr, steps, cycles, prefix=(), settings=()):
    cmd = [*prefix, str(host), str(binary), guid, binary.parent.parent.parent.as_uri() + "/resources",
           str(steps), "0.002", str(cycles), str(vr), *settings]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=600)


@pytest.mark.parametrize("model", sorted(CASES))
def test_native_binary_needs_only_libc_and_libm(unpacked, model):
    if shutil.which("readelf") is None:
        pytest.skip("readelf (binutils) not installed")
    binary = unpacked[model][0]
    dyn = subprocess.run(["readelf", "-d", str(binary)], capture_output=True, text=True, check=True).stdout
    needed = set(re.findall(r"\(NEEDED\)\s+Shared library: \[([^\]]+)\]", dyn))
    assert needed and all(re.match(r"lib(c|m)\.so", n) for n in needed), needed


@pytest.mark.parametrize("model", sorted(CASES))
def test_hundred_runs_in_a_c_host_without_python(host, unpacked, fmus_of, model):
    binary, guid, vr = unpacked[model]
    name, steps, expected = CASES[model]
    values, failures = set(), []
    for _ in range(100):
        proc = _run(host, binary, guid, vr, steps, 1)
        if proc.returncode != 0:
            failures.append((proc.returncode, proc.stderr[-500:]))
        else:
            values.add(float(proc.stdout.split()[0]))
    assert not failures, failures[:3]
    assert len(values) == 1
    expected = _expected(model, fmus_of)
    assert expected > 0.0 if model == "InductionMotor" else True
    assert values.pop() == pytest.approx(expected, rel=1e-12), name


@pytest.mark.parametrize("model", sorted(CASES))
def test_valgrind_finds_no_invalid_access_and_no_leak(host, unpacked, model):
    if shutil.which("valgrind") is None:
        pytest.skip("valgrind not installed (apt-get install valgrind)")
    binary, guid, vr = unpacked[model]
    proc = _run(host, binary, guid, vr, 20, 3, prefix=VALGRIND)
    _assert_valgrind_clean(proc)
    assert "Invalid read" not in proc.stderr and "Invalid write" not in proc.stderr


def test_valgrind_on_ball_in_a_spinning_bowl(host, unpacked):
    """BallInShell with motion = 2 (the chamber's reconstruction and the general
    model's kernel functions) in the C host under valgrind: a bowl spinning at 3 rad/s about
    the vertical through its fixed centre (inputs constant: O and A stay, Q's third column
    stays e_z), the ball started off-centre."""
    if shutil.which("valgrind") is None:
        pytest.skip("valgrind not installed (apt-get install valgrind)")
    from ballmill.fmi.interface import BALL_IN_SHELL as B

    binary, guid, vr = unpacked["BallInShell"]
    settings = (f"I{B.value_reference('motion')}=2", f"R{B.value_reference('Omega_z')}=3.0",
                f"R{B.value_reference('xC0')}=0.05")
    proc = _run(host, binary, guid, vr, 50, 2, settings=settings,
                prefix=VALGRIND)
    _assert_valgrind_clean(proc)
    assert 0.0 < float(proc.stdout.split()[0]) < 10.0  # N [N] of the ball pressed on the bowl


def test_valgrind_on_the_hybrid_ball(host, unpacked):
    """BallInShell with contact_model = 2 (the kernel's hybrid ball, bmh_interval, in every step and
    in the corrector's redo; the FMU state of a flying ball serialised, a changed byte refused, the
    intact one restored) in the C host under valgrind: a fixed chamber, the ball started rolling at
    the bottom at r wx0 = 2.4 m/s rolls up the wall, slips (mu = 0.3) at 0.18 s and leaves the wall
    at 0.25 s: after 0.3 s it flies (tests/test_hybrid_fmu_native.py), so the output read, N, is 0."""
    if shutil.which("valgrind") is None:
        pytest.skip("valgrind not installed (apt-get install valgrind)")
    from ballmill.fmi.interface import BALL_IN_SHELL as B

    binary, guid, vr = unpacked["BallInShell"]
    settings = (f"I{B.value_reference('contact_model')}=2", f"R{B.value_reference('wx0')}=96.0",
                f"R{B.value_reference('mu')}=0.3")
    proc = _run(host, binary, guid, vr, 150, 2, settings=settings,
                prefix=VALGRIND)
    _assert_valgrind_clean(proc)
    assert float(proc.stdout.split()[0]) == 0.0  # N [N] of the ball in flight


@pytest.mark.parametrize("model", sorted(CASES))
def test_thousand_instantiate_free_cycles_keep_rss_flat(host, unpacked, model):
    binary, guid, vr = unpacked[model]
    proc = _run(host, binary, guid, vr, 5, 1000)
    assert proc.returncode == 0, proc.stderr[-2000:]
    _, first, last = proc.stdout.splitlines()[0].split()
    assert int(last) - int(first) < 1024, (first, last)  # kB


@pytest.mark.parametrize("model", sorted(CASES))
def test_fmpy_builds_a_platform_binary_from_the_carried_sources(fmus_of, tmp_path, model):
    """What a user on another platform does: compile the FMU's sources/ (SourceFiles in its
    model description) with fmpy's CMake project, then run the result."""
    if shutil.which("cmake") is None:
        pytest.skip("cmake not installed")
    from fmpy import simulate_fmu
    from fmpy.build import build_platform_binary

    src = fmus_of("native")[model]
    unzip = tmp_path / "unzipped"
    zipfile.ZipFile(src).extractall(unzip)
    shutil.rmtree(unzip / "binaries")
    (tmp_path / "cmake").mkdir()
    build_platform_binary(unzip, tmp_path / "cmake")
    assert list((unzip / "binaries").rglob(f"{model}*"))
    start = {"xC0": 0.05} if model == "BallInShell" else {"F0_x": 1.0} if model == "Structure" else {}
    res = simulate_fmu(str(unzip), stop_time=1.0, output_interval=0.01, start_values=start)
    ref = simulate_fmu(str(src), stop_time=1.0, output_interval=0.01, start_values=start)
    for name in res.dtype.names:  # the same sources, the same compiler family: the same numbers
        assert res[name] == pytest.approx(ref[name], rel=1e-12, abs=1e-15), name
    if model == "MotorStartup":
        assert res["psi_dot"][-1] == pytest.approx(2.0 * math.pi * 0.64, rel=1e-12)
    elif model == "BallInShell":  # the ball released at xC0 = 0.05 m swings through the bottom
        assert res["xC"].min() < -0.045
    elif model == "Structure":  # 1 N at resonance on 100 kg from rest: x ~ F t sin(w t) / (2 M w)
        assert 0.0 < res["x_rel"].max() < 1.0 / (2 * 100.0 * 2 * math.pi * 0.8)
        assert res["W_exc"][-1] > 0.0
    elif model == "Fig1Drive":  # the frame at 0.5 rad/s, the cranks' law as MotorStartup's
        assert res["phi"][-1] == pytest.approx(0.5, rel=1e-12)
        assert res["psi_dot"][-1] == pytest.approx(2.0 * math.pi * 0.64, rel=1e-12)
    else:  # the unloaded, frictionless motor runs up to its synchronous speed 2 pi 50 / 2 / i
        assert 0.95 * math.pi * 50 / 24 < res["psi_dot"][-1] <= (1 + 1e-9) * math.pi * 50 / 24


# FMI 3.0 co-simulation through an early return: model -> (settings by name, output, steps of 2 ms,
# the time the step returns early at, tolerance [s], the output's value after the steps)
EARLY = {
    # the ball spun at wy0 = -20 rad/s slips (mu = 0.1) at the library's 0.18832367832772445 s
    # (tests/test_fmi3.py); the step returned early there latches valid: t_invalid is that time
    "BallInShell": (dict(wy0=-20.0, mu=0.1), "t_invalid", 100, 0.18832367832772445, 1e-9, None),
    # the start-up law's time event at t0 (off the 2 ms grid), after which psi' = w0 = 1 rev/s
    "MotorStartup": (dict(t0=0.0513), "psi_dot", 50, 0.0513, 1e-12, 2.0 * math.pi),
}


@pytest.mark.parametrize("model", sorted(EARLY))
def test_valgrind_on_fmi3_early_return_and_event_mode(host3, tmp_path_factory, fmu_build_dir, model):
    """FMI 3.0 co-simulation in the C host (tests/hosts/fmi_host.c built for FMI 3.0) under
    valgrind, 2 cycles: instantiated with eventModeUsed and earlyReturnAllowed, the step that meets
    the event returns early at lastSuccessfulTime, the host enters event mode, updates the discrete
    states, enters step mode and goes on to the end; the serialised state's check as in FMI 2.0.
    0 errors, no definitely lost block, the event at its known time."""
    if shutil.which("valgrind") is None:
        pytest.skip("valgrind not installed (apt-get install valgrind)")
    from ballmill.fmi.interface import INTERFACES

    settings, output, steps, t_event, tol, expected = EARLY[model]
    path = fmu_build_dir / "fmi3" / f"{model}.fmu"
    md = read_model_description(str(path))
    d = tmp_path_factory.mktemp(f"{model}3")
    zipfile.ZipFile(path).extractall(d)
    binary = d / "binaries" / native.platform_dir_fmi3() / f"{model}{native.shared_suffix()}"
    vr = INTERFACES[model].value_reference
    cmd = [*VALGRIND, str(host3), str(binary), md.guid, str(d / "resources") + "/", str(steps),
           "0.002", "2", str(vr(output)), *(f"R{vr(name)}={value!r}" for name, value in settings.items())]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    _assert_valgrind_clean(proc)
    first, second = proc.stdout.splitlines()
    value = float(first.split()[0])
    events, n, early, *times = second.split()
    assert (events, early, int(n)) == ("events", "early", 2)  # after the initialisation and at the event
    assert len(times) == 1 and abs(float(times[0]) - t_event) < tol, times
    assert value == (float(times[0]) if expected is None else pytest.approx(expected, rel=1e-12))


def test_valgrind_on_model_exchange_in_a_c_host(unpacked, fmus_of, tmp_path):
    """BallInShell's Model Exchange in a C host (tests/hosts/me_host.c) under valgrind: 3 cycles of
    instantiate, initialise, 0.3 s of explicit Euler through setTime/setContinuousStates/
    getDerivatives/getEventIndicators with an event update at each sign change (the ball rolls up
    the wall from the bottom at wy0 = -20 rad/s and begins to slip at 0.188 s with mu = 0.1: valid
    latches false), FMU state get/serialise/deserialise/restore, a changed byte and a NaN state
    refused, setTime backwards refused; no invalid access, no definitely lost block."""
    if shutil.which("valgrind") is None:
        pytest.skip("valgrind not installed (apt-get install valgrind)")
    exe = tmp_path / "me_host"
    proc = subprocess.run(["cc", "-O2", "-Wall", "-Wextra", "-Werror", "-I", str(native.fmi_headers_dir()),
                           str(HOST.parent / "me_host.c"), "-o", str(exe), "-ldl", "-lm"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    md = read_model_description(str(fmus_of("native")["BallInShell"]))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    binary, guid, _ = unpacked["BallInShell"]
    cmd = [*VALGRIND, str(exe),
           str(binary), guid, "3", str(md.numberOfContinuousStates), str(md.numberOfEventIndicators),
           str(vr["valid"]), str(vr["wy0"]), "-20", str(vr["mu"]), "0.1"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr[-2000:]
    assert proc.stdout.split() == ["valid", "0", "ok"]
    assert "definitely lost: 0" in proc.stderr or "no leaks are possible" in proc.stderr


SANITIZE = ["-O1", "-fsanitize=address,undefined", "-fno-omit-frame-pointer", "-fno-sanitize-recover=all"]


@pytest.fixture(scope="module")
def sanitized(tmp_path_factory):
    """The host and every model's staged sources compiled with AddressSanitizer and
    UndefinedBehaviorSanitizer (all compilers at once): model -> (binary, guid, resources)."""
    base = tmp_path_factory.mktemp("sanitized")
    cmds = {"host": [native.compiler(), *SANITIZE, "-I", str(native.fmi_headers_dir()), str(HOST),
                     "-o", str(base / "fmi_host"), "-ldl"]}
    out = {}
    for model in CASES:
        src = base / model / "sources"
        binary = base / model / "binaries" / native.platform_dir() / f"{model}{native.shared_suffix()}"
        guid, units = native.stage_sources(model, src)
        binary.parent.mkdir(parents=True)  # the archive's layout: _run finds resources/ from it
        (base / model / "resources").mkdir()
        cmds[model] = [native.compiler(), *native.CFLAGS, *SANITIZE, "-shared", "-I", str(src),
                       *[str(src / u) for u in units], "-o", str(binary), "-lm"]
        out[model] = (binary, guid)
    procs = {k: subprocess.Popen(c, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
             for k, c in cmds.items()}
    failed = {k: p.communicate()[1][-1500:] for k, p in procs.items() if p.wait() != 0}
    if failed and all("asan" in e.lower() or "sanitizer" in e.lower() for e in failed.values()):
        pytest.skip(f"this compiler has no sanitizer runtime: {failed}")
    assert not failed, failed
    return base / "fmi_host", out


@pytest.mark.parametrize("model", sorted(CASES))
def test_sanitizers_find_nothing(sanitized, unpacked, fmus_of, model):
    host, built = sanitized
    binary, guid = built[model]
    vr = unpacked[model][2]
    proc = _run(host, binary, guid, vr, 50, 2)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "runtime error" not in proc.stderr and "Sanitizer" not in proc.stderr, proc.stderr[-3000:]
    # the same physics as the optimised build (-ffp-contract=off: no fused operations either way)
    assert float(proc.stdout.split()[0]) == pytest.approx(_expected(model, fmus_of), rel=1e-12)
