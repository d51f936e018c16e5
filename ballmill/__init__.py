"""ballmill: a ball rolling inside a moving spherical chamber, as FMI co-simulation FMUs.

Subpackages: ``physics`` (equations, integrators; no FMI), ``fmi`` (FMU
building blocks and the builder), ``scenario`` (the fmpy-based runner).
This file stays light: the FMUs bundle the package and import it at load time.
"""
__version__ = "0.1.0"
