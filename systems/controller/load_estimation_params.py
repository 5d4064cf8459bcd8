"""The settings of the load estimator in the loop (Fig. 4): fixed or learned online, and how.

``controller.estimator`` of a scenario. With ``mode`` "online" the controller Diagram wires
``AccelerometerToMotion``, ``EstimatorGate``, ``EstimatorPrefilter``, ``RlsLoadEstimator``, ``RestLearner``
and ``GraspSplit`` (``diagrams.online_estimation``).
"""

import dataclasses
import math


ESTIMATOR_MODES = ("fixed", "online")
ONLINE_METHODS = ("rls",)


@dataclasses.dataclass
class LoadEstimationParams:
    """The load estimate the controller uses: ``fixed`` (the estimate file's φ̂) or ``online``
    (``method`` updating φ̂ every tick while ``EstimatorGate`` allows, starting from the
    estimate file's and, on a new load, forgetting the data but keeping the estimate)."""

    mode: str = "fixed"
    method: str = "rls"
    forgetting: float = 0.9995
    """λ per tick: a memory of 1/(1 − λ) = 2000 ticks, 1 s at 2 kHz."""

    prior_covariance: float = 1.0
    """P₀ of the RLS's prior on the estimate it starts from, and keeps on a new load (per entry of φ:
    kg², (kg·m)², (kg·m²)²): how far a sample may pull φ̂ in the directions it barely excites; the
    stabilized forgetting relaxes those directions to it. 1 lets a grasped object's mass in at its
    first samples, but not one sample's noise into what the motion hardly sees: with 1e6 (no prior)
    the first sample of strokes started past ``learning_window`` set the gripper's I_yy to
    −2.9 kg·m² to fit 0.06 N, and the contact that φ̂ then saw closed the gate for good."""

    min_excitation: float = 2.0
    """Least ‖V(a, α, ω, 0)‖ (Frobenius; m/s², rad/s², rad²/s² mixed) of a sample taken."""


    learning_window: float = 1.5
    """Time (s) after a reset during which contact is not judged (the new load is learned)."""

    new_load_wait: float = 0.0
    """Time (s) after a reset before a sample is taken: the prefilter still carries the old load
    for some 2/``prefilter`` s, and a load that lands on a compliant mount rings meanwhile; 0
    learns at once (the simulation's grasp, made at rest, learns fastest so)."""

    rest_window: float = 0.05
    """Length (s) of the averages ``RestLearner`` compares at rest after a grasp: two in a row that agree and
    leave a wrench φ̂ does not explain give the object's mass and the static moment the pose shows."""

    rest_agreement: float = 0.02
    """How far (a fraction of the newer's magnitude, plus one sample's noise) two averages at rest may lie
    apart for the step at the grasp to count as settled (``RestLearner``)."""

    prefilter: float = 10.0
    """Cut-off (Hz) of the low-pass on both sides of W = V·φ before the estimator
    (``EstimatorPrefilter``): below the load's mount modes and above the operator's motion;
    0: none. The gate judges the unfiltered samples."""

    max_input_age: float = 0.005
    """Oldest (s) the station's readings (the master's, the arm's and the wrist sensor's, by their
    wall-clock ages on hardware) may be at a tick that is learned from. A lab that stalls and then
    catches up jerks the arm, and the load rings on its compliant mount for a tenth of a second and
    more; a tick with older readings spoils the sample as a fault does (``EstimatorGate``: the gate
    stays closed 2/``prefilter`` s after it). The simulated station's readings are never older than a
    tick. inf: never judged."""

    def validate(self) -> None:
        if self.mode not in ESTIMATOR_MODES:
            raise ValueError(f"estimator mode must be one of {ESTIMATOR_MODES}; got {self.mode!r}")
        if self.method not in ONLINE_METHODS:
            raise ValueError(f"online estimator method must be one of {ONLINE_METHODS}: it starts from the "
                             f"estimate and keeps it as the prior on a new load (RIV would need encoder-derived "
                             f"instruments, RTLS a prior mean); got {self.method!r}")
        if not 0.5 <= self.forgetting <= 1.0:
            raise ValueError(f"estimator forgetting must lie in [0.5, 1]; got {self.forgetting}")
        if not (math.isfinite(self.prior_covariance) and self.prior_covariance > 0):
            raise ValueError(f"estimator prior_covariance must be finite and > 0; got {self.prior_covariance}")
        if not (math.isfinite(self.rest_window) and self.rest_window > 0):
            raise ValueError(f"estimator rest_window must be finite and > 0 s; got {self.rest_window}")
        if not self.max_input_age > 0:  # NaN too
            raise ValueError(f"estimator max_input_age must be > 0 s (inf: never judged); got {self.max_input_age}")
        for name in ("min_excitation", "learning_window", "new_load_wait", "prefilter", "rest_agreement"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"estimator {name} must be finite and >= 0; got {value}")
