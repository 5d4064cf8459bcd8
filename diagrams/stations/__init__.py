"""The stations the controller connects to by port name: the simulated one, the
stand-in lab on LCM, and the bare load-on-sensor plant."""
