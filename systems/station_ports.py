"""The ports a station offers the controller, by name: the simulated station and the lab's hardware station
have them alike (docs/design.md §3), so that one function connects the controller to either."""

STATION_OUTPUTS_READ = ("master.position_measured", "master.velocity_estimated", "slave.position_measured",
                        "slave.velocity_estimated", "ft.wrench_measured", "ft.acceleration_measured")
"""What the controller reads of a station: q_M, q̇_M (the master's 6 joints), q_S, q̇_S (the arm's n; rad, rad/s),
the wrench [f; τ] on the load at S in S (N, N·m) and the accelerometer's reading (``accelerometer_reading``)."""
STATION_INPUTS_DRIVEN = ("master.torque_commanded", "slave.position_commanded")
"""What the controller drives: τ_M (6, N·m) and q̄_S (n, rad)."""
CLUTCH = "clutch"
"""The station's clutch (1: > 0.5 engaged): the master's button on hardware, held in simulation."""
INPUT_AGE = "input_age"
"""How old (s) the oldest reading of the tick is, where a station knows (hardware)."""
