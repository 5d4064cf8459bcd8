"""The simulated station's models: the sensors, the encoders, the operator's hand, the arm's servo, the truth."""
