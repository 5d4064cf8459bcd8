"""Studies over many simulations: apparent mass, stability sweeps, the linear model's parameters."""
