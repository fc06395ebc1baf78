"""The command layer: one module per `trackdyn` command."""
