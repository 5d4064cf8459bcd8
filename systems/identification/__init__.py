"""Identifying the load (Sec. IV): excitation, the batch and recursive estimators, static calibration."""
