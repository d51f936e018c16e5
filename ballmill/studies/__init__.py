"""Studies that measure the models against each other; each writes a page in docs/.

    python -m ballmill.studies.coupling     coupling error of BallInShell against the step, per input path
    python -m ballmill.studies.induction    induction motor: coupling error, starts compared
    python -m ballmill.studies.design       the mill's design study (ballmill sweep): docs/design_study.md
    python -m ballmill.studies.fig1         the whole machine of Fig. 1, spinning bowl, tumbling drum: docs/fig1_machine.md
    python -m ballmill.studies.absorber     ball absorber on a structure: FRF, sweeps, tuning, ground record
"""
