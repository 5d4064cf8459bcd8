"""Running things: the simulation of the closed loop, the real-time loop and the
hardware runs on it, recording."""
