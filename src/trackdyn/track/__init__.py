"""Track side: support model, track input, synthetic tracks, geometry quality."""
