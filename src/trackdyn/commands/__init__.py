"""The command layer: one package per `trackdyn` command, with its file model, outputs and
figures, and the modules only commands use.

A command reads its input files, calls the library (track, vehicle, solver, simulation,
studies, deterioration, calibration), writes its outputs into a staged output folder
(`trackdyn.commands.staging`: netCDF files through `trackdyn.commands.netcdf`, the page
through `trackdyn.commands.report`) and shows its tables (`trackdyn.commands.tables`).
`trackdyn.cli` parses the command line and calls these; no library module imports this
package.
"""
