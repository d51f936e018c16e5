"""ballmill.physics.drives: what moves the platform, and the drive coupled to the ball.

``crank`` holds the prescribed platform motions (the paper's crank start-up law
`CrankStartup` with its angle laws ``LAWS``, and `Circle`, `Harmonic`, `Fixed`);
``induction`` the induction motor that turns the crank through a gear and sags
under the ball's reaction torque (`InductionMotor`, `CrankDrive`, `simulate_runup`,
docs/design.md section 4); ``coupled`` the monolithic reference with motor, crank,
platform and ball in one ODE (`simulate_coupled`), against which co-simulation
coupling errors are measured. Plain Python, SI units, no FMI.
"""
from .crank import LAWS, Circle, CrankStartup, Fixed, Harmonic

# induction and coupled need scipy: loaded on first use of one of their names, so that
# importing ballmill.physics (and the BallInShell FMU) does not import scipy
_LAZY = {
    "induction": ("DRIVE_MODELS", "RPM", "START_MODES", "CrankDrive", "DqParameters", "InductionMotor",
                  "RunupResult", "platform_state", "simulate_runup"),
    "coupled": ("CoupledResult", "CoupledSystem", "simulate_coupled"),
}

__all__ = ["LAWS", "Circle", "CrankStartup", "Fixed", "Harmonic",
           *_LAZY["induction"], *_LAZY["coupled"]]


def __getattr__(name):
    for module, names in _LAZY.items():
        if name in names:
            from importlib import import_module
            return getattr(import_module(f".{module}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
