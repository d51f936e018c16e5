"""`CrankStartup.angles`, the array form the studies use, against `angle` (the scalar law the
kernel and the FMUs follow) sample by sample, for every law, before t = 0, during the rise, at
t0 exactly and after it (mutants of `angles` survived: no other test reads it)."""
import numpy as np
import pytest

from ballmill.physics.drives.crank import LAWS, CrankStartup


@pytest.mark.parametrize("law", LAWS)
def test_angles_are_angle_at_every_sample(law):
    drive = CrankStartup(l=0.4, n0=70.0, t0=1.7, law=law)
    t = np.array([-0.5, 0.0, 0.2, 0.85, 1.3, 1.7, 1.9, 4.0])
    psi, wd, wdd = drive.angles(t)
    for k, tk in enumerate(t):
        want = drive.angle(float(tk))
        assert (psi[k], wd[k], wdd[k]) == pytest.approx(want, rel=1e-13, abs=1e-13), (law, tk)
    assert psi.shape == wd.shape == wdd.shape == t.shape


# the speed rise of each law as its docstring writes it (tau = t / t0), and c in psi(t0) = c w0 t0
RATE = {"quadratic": (lambda tau: 1.0 - (1.0 - tau) ** 2, 2.0 / 3.0),
        "linear": (lambda tau: tau, 0.5),
        "scurve": (lambda tau: tau * tau * (3.0 - 2.0 * tau), 0.5),
        "quintic": (lambda tau: tau ** 3 * (10.0 - 15.0 * tau + 6.0 * tau * tau), 0.5)}


@pytest.mark.parametrize("law", LAWS)
def test_rise_angle_is_the_documented_law(law):
    """psi' from the documented rate, psi its integral from 0 (quadrature), psi'' its
    derivative (central difference); after t0 the steady rotation from c w0 t0; at rest
    before 0; at t0 itself the rise's own (left) values, as the kernel's crank_law.h."""
    from scipy.integrate import quad

    from ballmill.physics.drives.crank import rise_angle

    w0, t0 = 6.1, 1.3
    rate, c = RATE[law]
    for t in (0.1, 0.45, 0.9, 1.25, t0):
        psi, wd, wdd = rise_angle(law, w0, t0, t)
        assert wd == pytest.approx(w0 * rate(t / t0), rel=1e-13), (law, t)
        assert psi == pytest.approx(quad(lambda x: w0 * rate(x / t0), 0.0, t, epsabs=1e-14)[0], rel=1e-11)
        h = 1e-5
        fd = w0 * (rate((t + h) / t0) - rate((t - h) / t0)) / (2 * h)
        assert wdd == pytest.approx(fd, rel=1e-7, abs=1e-7), (law, t)
    assert rise_angle(law, w0, t0, t0)[0] == pytest.approx(c * w0 * t0, rel=1e-13)
    for t in (t0 + 1e-9, 2.0, 7.5):
        assert rise_angle(law, w0, t0, t) == pytest.approx((c * w0 * t0 + w0 * (t - t0), w0, 0.0),
                                                           rel=1e-13, abs=1e-13), (law, t)
    assert rise_angle(law, w0, t0, -0.3) == (0.0, 0.0, 0.0)


def test_an_unknown_law_is_refused_by_name():
    from ballmill.physics.errors import ParameterError

    with pytest.raises(ParameterError) as err:
        CrankStartup(law="cubic")
    assert str(err.value) == "law must be one of quadratic, linear, scurve, quintic, got law = 'cubic'"
