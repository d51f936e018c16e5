"""BallModel and simulate at their edges, word for word (survivors of the physics core's
mutation run): the work bound max_steps reaches the integrator, and a state of the wrong
size is refused with the formulation's coordinates named."""
import numpy as np
import pytest

from ballmill.physics.drives.crank import CrankStartup
from ballmill.physics.errors import ParameterError
from ballmill.physics.model import BallModel, BallState, simulate
from ballmill.physics.params import Ball


def test_max_steps_bounds_the_integrators_work():
    """DOP853 at tol 1e-9 needs more than 3 internal steps for half a second of the start;
    with max_steps = 3 the run stops there and says so; by default it completes."""
    for kernel in ("python", "auto"):
        model = BallModel(Ball(), max_steps=3, kernel=kernel)
        tr = simulate(model, CrankStartup(), 0.5, 0.5, model.initial(0.0))
        assert not tr.success
        assert "DOP853: more than 3 internal steps between t = 0" in tr.message
        model = BallModel(Ball(), kernel=kernel)
        assert simulate(model, CrankStartup(), 0.5, 0.5, model.initial(0.0)).success


@pytest.mark.parametrize("formulation, size, names, wrong", [("vector", 6, "n, omega", 5),
                                                              ("paper", 5, "xC, yC, omega", 6)])
def test_a_state_of_the_wrong_size_is_refused_with_the_coordinates_named(formulation, size, names, wrong):
    model = BallModel(Ball(), formulation=formulation, kernel="python")
    with pytest.raises(ParameterError) as err:
        simulate(model, CrankStartup(), 0.5, 0.1, BallState(0.0, np.zeros(wrong), None))
    assert str(err.value) == (f"state.y must hold the {size} coordinates of the {formulation!r} "
                              f"formulation ({names}), got shape ({wrong},)")
