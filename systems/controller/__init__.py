"""The controller's blocks (Fig. 4): each a TickSystem around the kernels it declares, with its settings."""
