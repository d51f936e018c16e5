"""ballmill.absorber: ball vibration absorbers on a linear structure: the physics and its analysis.

    structure the structure that carries the ball's cavity (docs/design.md section 11):
              modes, the two horizontal axes, the excitations (harmonic force or
              ground, a ground record) and `StructureModel`, its equations with
              the ball's force as an input.
    model     the monolithic structure + ball model: one ODE, the algebraic loop
              solved exactly (`StructureBall`, `simulate_absorber`, `simulate_structure`).
    linear    the linear theory: the small-oscillation model of structure + rolling
              ball (closed-form frequency response), its equivalent classic tuned-mass
              damper, Den Hartog's optimum, the cavity radius that tunes the ball,
              a numerical optimum of frequency and damping.
    response  the nonlinear model's steady-state amplitude at one frequency (with an
              error estimate and validity), frequency responses with the grid refined
              where they peak, stepped up/down sweeps that continue from the last state.

``structure`` and ``model`` are plain physics (numpy, SI units, no analysis, no FMI)
on the ball of ballmill.physics; the others analyse them.
"""
