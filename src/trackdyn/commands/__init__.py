"""The command layer: one module per `trackdyn` command, with its file model, outputs and
figures.

A command reads its input files, calls the library (track, vehicle, solver, simulation,
studies, deterioration), writes its outputs into a staged output folder
(`trackdyn.staging`) and shows its tables (`trackdyn.commands.tables`). `trackdyn.cli`
parses the command line and calls these; no library module imports this package.
"""
