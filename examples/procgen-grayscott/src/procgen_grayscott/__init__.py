"""Gray-Scott reaction-diffusion for procgen: spots, stripes and coral from two chemicals."""
