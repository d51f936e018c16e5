"""ballmill.scenario: scenario files, the fmpy-based co-simulation runner and its reports.

``spec`` reads a scenario (TOML, one file a scenario in scenarios/) and
checks it against the FMUs' model descriptions; ``runner`` steps the FMU
instances on fmpy; ``report`` writes results.csv, summary.json and plots.
"""
