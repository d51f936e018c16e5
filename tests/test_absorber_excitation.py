"""Excitations of the structure (ballmill.absorber.structure), the bare-structure
reference run, the synthetic ground record and its generator, the summary."""
import csv
import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

from ballmill.absorber.linear import LinearAbsorber, den_hartog_ball
from ballmill.absorber.summary import structure_summary
from ballmill.absorber.model import StructureBall, simulate_absorber, simulate_structure
from ballmill.absorber.structure import GroundRecord, HarmonicForce, HarmonicGround, Structure

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "scenarios" / "data"


def test_chirp_phase_and_frequency():
    """theta' = 2 pi f(t) for a slowly varying frequency, and a retuned force continues
    with the phase it had."""
    exc = HarmonicForce(2.0, 0.5, sweep_rate=0.01, phase=0.3, t0=1.0)
    for t in (1.0, 7.3, 40.0):
        h = 1e-5
        dtheta = (exc.theta(t + h) - exc.theta(t - h)) / (2 * h)
        assert dtheta == pytest.approx(2 * math.pi * exc.instantaneous_frequency(t), rel=1e-8)
    new = exc.retuned(0.9, 12.0)
    assert math.sin(new.theta(12.0)) == pytest.approx(math.sin(exc.theta(12.0)), abs=1e-12)
    assert new.loads(12.0)[0] == pytest.approx(exc.loads(12.0)[0], abs=1e-12)
    assert new.instantaneous_frequency(20.0) == 0.9


@pytest.mark.parametrize("load", ["force", "ground"])
def test_bare_structure_reaches_the_closed_form(load):
    """The bare-structure run (the absorber's reference) settles on the linear closed
    form: a well damped axis, 60 s, last 10 s compared sample by sample."""
    st = Structure.single(80.0, 1.1, 0.08, both_axes=False)
    f = 0.9
    exc = HarmonicForce(3.0, f) if load == "force" else HarmonicGround(0.4, f)
    res = simulate_structure(st, exc, 60.0, 0.01, tol=1e-10)
    X = LinearAbsorber(st.x).frf(f, load)[0] * (3.0 if load == "force" else 0.4)
    t = res.t[res.t >= 50.0]
    exact = (X * np.exp(1j * 2 * math.pi * f * t)).imag
    assert np.abs(res["xO"][res.t >= 50.0] - exact).max() < 1e-6 * abs(X)
    resid = res["W_exc"] - (res["E"] - res["E"][0]) - res["W_damp"]
    assert np.abs(resid).max() < 1e-8 * np.abs(res["W_exc"]).max()


def _load_generator():
    spec = importlib.util.spec_from_file_location("make_ground_motion", DATA / "make_ground_motion.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_ground_record_is_what_its_generator_writes():
    gen = _load_generator()
    t, ax, ay = gen.record()
    rec = GroundRecord.from_csv(DATA / "ground_motion.csv")
    assert np.allclose(rec.t, t, atol=1e-9)
    assert np.abs(np.array(rec.ax) - ax).max() <= 1e-6
    assert np.abs(np.array(rec.ay) - ay).max() <= 1e-6
    assert np.abs(rec.ax).max() == pytest.approx(gen.PGA[0], abs=1e-6)
    assert np.abs(rec.ay).max() == pytest.approx(gen.PGA[1], abs=1e-6)
    # baseline-corrected: the ground ends at rest where it started (velocity and
    # displacement integrated from the CSV, against their peaks)
    for a in (np.array(rec.ax), np.array(rec.ay)):
        v = gen._integrate(t, a)
        x = gen._integrate(t, v)
        assert abs(v[-1]) < 1e-3 * np.abs(v).max()
        assert abs(x[-1]) < 1e-3 * np.abs(x).max()


def test_damped_ball_reduces_the_structures_response_to_the_record():
    """Structure + Den Hartog ball under the first 25 s of the record against the bare
    structure: smaller RMS displacement, the ball rolls, the energy books close."""
    rec = GroundRecord.from_csv(DATA / "ground_motion.csv")
    st = Structure.single(100.0, 0.8, 0.01)
    ball = den_hartog_ball(st.x, 0.025, 2.0)
    res = simulate_absorber(StructureBall(st, ball, rec), 25.0, 0.02, x_ref=1e-2)
    bare = simulate_structure(st, rec, 25.0, 0.02, x_ref=1e-2)
    s = structure_summary(res.t, res.data, bare.data, mu=ball.mu)
    assert s["reduction_displacement_rms_percent"] > 10.0
    assert s["rolling"] and s["contact"]
    assert 0 < s["ball_angle_max_deg"] < 60
    assert np.abs(res.energy_residual).max() < 1e-8 * res["W_exc"].max()
    with open(DATA / "ground_motion.csv") as fh:
        assert next(csv.reader(fh)) == ["time", "ax", "ay"]
