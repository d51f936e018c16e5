"""ballmill.absorber: ball vibration absorbers on a linear structure, analysed.

    linear    the linear theory: the small-oscillation model of structure + rolling
              ball (closed-form frequency response), its equivalent classic tuned-mass
              damper, Den Hartog's optimum, the cavity radius that tunes the ball,
              a numerical optimum of frequency and damping.
    response  the nonlinear model's steady-state amplitude at one frequency (with an
              error estimate and validity), frequency responses with the grid refined
              where they peak, stepped up/down sweeps that continue from the last state.

The physics these build on (plain, no analysis) is ballmill.physics.structure (the
modal structure and its excitations) and ballmill.physics.absorber (structure + ball
in one ODE).
"""
