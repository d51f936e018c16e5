"""ballmill.fmi: building blocks shared by the FMU adapters, and the builder.

``slave`` holds the pythonfmu base class that adds what pythonfmu leaves out
(units, min/max, output dependencies, InitialUnknowns, full state
save/restore); it is bundled into every FMU. ``build`` turns the adapter
scripts in fmu_src/ and drive_models/ into FMUs in build/ and validates them.
"""
