"""Generic rules every family needs (sampling, meshing, noise, smoothing), registered like plugins."""
