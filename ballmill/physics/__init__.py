"""ballmill.physics: the ball rolling without slip in a moving spherical chamber.

Plain Python and numpy, SI units, no FMI and no I/O. The FMU adapters in
fmu_src/ and drive_models/ and the scenario runner build on this package.

    from ballmill.physics import Ball, BallModel, CrankStartup, simulate
    model = BallModel(Ball())                  # the paper's ball, vector form
    traj = simulate(model, CrankStartup(t0=2.5), t_end=10.0, dt=0.01)
    traj["zP"], traj["N"]

What it owns, here: the ball (params.py, the two formulations of equations.py,
outputs.py, the model and its monolithic driver model.py, the input reconstruction
of platform.py, the quasi-static calculator steady.py, errors.py) and its numerics
(integrators.py; the compiled kernel fast.py over _kernel.c). Two subpackages:

* ``drives/``: what moves the platform: the prescribed platform motions
  (``drives.crank``: CrankStartup and its laws, Circle, Harmonic, Fixed), the
  induction motor on the crank (``drives.induction``) and the monolithic
  motor + crank + ball reference (``drives.coupled``).
* ``turning/``: a chamber that moves in 3-D and turns (docs/design.md section 10): the
  motions (``turning.motions``: Translation, Spin, Fig1Machine), the general model
  (``turning.model``: equations, outputs with the drives' reaction moments, first
  integrals) and its compiled functions (``turning.kernel``). `simulate_chamber` runs
  a scene, a Translation on the translation-only model above (unchanged), anything
  else on `ChamberModel` (compiled bmg_* functions when built).

    from ballmill.physics import Ball, Fig1Machine, simulate_chamber
    traj = simulate_chamber(Ball(), Fig1Machine(), t_end=10.0, dt=0.01)
    traj["Pch_x"], traj["N"], traj["M1"], traj["M2"]

Beyond rolling (docs/design.md section 14): ``hybrid.simulate_hybrid`` runs the ball that
rolls, slides, flies and strikes a translating chamber, on the event-driven driver of
``events`` (``Contact`` holds mu_k, e_n, v_rest).

    from ballmill.physics import Ball, Contact, CrankStartup, simulate_hybrid
    traj = simulate_hybrid(Ball(), CrankStartup(t0=0.5), t_end=1.0, dt=0.01, contact=Contact(e_n=0.5))
    traj["mode"], traj["slip_speed"], traj.events

The absorber's structure and the structure + ball model are in ``ballmill.absorber``.

Monolithic runs, and `BallModel.advance` driven by InputReconstruction's cubic
input (the BallInShell FMU's steps), use a compiled kernel (`fast`, built from
_kernel.c at install time) when it is available and covers the run, with the
same results bit for bit; ``KERNEL_AVAILABLE`` says whether it is,
``KERNEL_REASON`` why not.
"""
# the names above, each from its module, imported when first asked for (PEP 562): a process
# that needs one module (a scenario run: the drives, the outputs) does not import them all
_FROM = {
    ".drives.crank": ("Circle", "CrankStartup", "Fixed", "Harmonic"),
    ".equations": ("PaperFormulation", "VectorFormulation", "make_formulation", "omega_dot_cramer"),
    ".errors": ("FormulationLimitError", "InputError", "ParameterError", "StepFailure"),
    ".fast": ("KernelUnavailable", "KERNEL_AVAILABLE", "KERNEL_REASON"),
    ".hybrid": ("HybridTrajectory", "simulate_hybrid"),
    ".integrators": ("METHODS", "Integrator"),
    ".model": ("BallModel", "BallState", "Trajectory", "simulate"),
    ".outputs": ("Outputs", "energy", "evaluate", "spin"),
    ".params": ("Ball", "Contact", "steel_ball_mass"),
    ".platform": ("INPUT_MODES", "InputReconstruction"),
    ".turning.model": ("ChamberModel", "ChamberOutputs", "simulate_chamber", "simulate_general"),
    ".turning.motions": ("ChamberState", "ConstantSpeed", "Fig1Machine", "Spin", "Translation"),
}
_RENAMED = {"INPUT_MODES": "MODES"}  # platform.MODES, exported as INPUT_MODES
_MODULE = {name: module for module, names in _FROM.items() for name in names}

__all__ = [
    "Ball", "BallModel", "BallState", "ChamberModel", "Contact", "HybridTrajectory", "simulate_hybrid", "ChamberOutputs", "ChamberState", "Circle",
    "ConstantSpeed", "Fig1Machine", "Spin", "Translation", "simulate_chamber", "simulate_general", "CrankStartup", "Fixed", "FormulationLimitError",
    "Harmonic", "INPUT_MODES", "InputError", "InputReconstruction", "Integrator", "KERNEL_AVAILABLE",
    "KERNEL_REASON", "KernelUnavailable", "METHODS",
    "Outputs", "PaperFormulation", "ParameterError", "StepFailure", "Trajectory",
    "VectorFormulation", "energy", "evaluate", "make_formulation", "omega_dot_cramer",
    "simulate", "spin", "steel_ball_mass",
]


def __getattr__(name):
    """A name of __all__, from its module (KERNEL_AVAILABLE, a bool, and KERNEL_REASON, a str,
    '' when available, from fast, which loads the compiled kernel on first use rather than on
    import); or a submodule."""
    import importlib

    module = _MODULE.get(name)
    if module is not None:
        value = getattr(importlib.import_module(module, __name__), _RENAMED.get(name, name))
        if name not in ("KERNEL_AVAILABLE", "KERNEL_REASON"):  # these two: asked of fast each time
            globals()[name] = value
        return value
    try:
        return importlib.import_module(f"{__name__}.{name}")
    except ModuleNotFoundError as e:
        if e.name != f"{__name__}.{name}":
            raise
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
