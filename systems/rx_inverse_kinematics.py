"""Closed-form kinematics of the Stäubli RX90 / RX60 (6R, spherical wrist), plain numpy.

Modified DH (Craig / Khalil–Kleinfinger), rows (α_{i−1}, a_{i−1}, θ_i, d_i), as in
diagrams/models/rx90.urdf, rx60.urdf and SOURCES.md:

    1: (0,     0,   q1,        d1)
    2: (−π/2,  0,   q2 − π/2,  0 )
    3: (0,     a2,  q3 − π/2,  d3)     d3: lateral offset along the J2/J3 axes (RX60 only)
    4: (−π/2,  0,   q4,        d4)
    5: (π/2,   0,   q5,        0 )
    6: (−π/2,  0,   q6 + π,    d6)

Frame 0 is the base R, frame 6 the flange F. q = 0 is the arm straight up with F parallel to R.

Inverse kinematics. The wrist centre p_C = p_RF − d6·z_F moves with q1..q3 only:

    p_C = Rz(q1)·(x1, d3, 0) + (0, 0, d1 + z1),
    x1 = a2 sin q2 + d4 sin(q2 + q3),   z1 = a2 cos q2 + d4 cos(q2 + q3),

so q1 = atan2(y, x) − atan2(d3, x1) with x1 = ±√(x² + y² − d3²) (shoulder front / back),
cos q3 follows from the law of cosines (elbow ±), and q2 from the planar two-link arm.
The wrist is a Y–Z–Y Euler set, R_36·Rx(π/2) = Ry(q4)·Rz(q5)·Ry(q6 + π), with two
solutions (the wrist flip: q4 + π, −q5, q6 + π). That gives up to 8 solutions.

Singularities. Shoulder (wrist centre on the J1 axis, RX90 only): q1 is free and keeps the
reference value; passing through the axis, the nearest branch switches from shoulder front to
back with q1 continuous. Elbow (arm stretched, q3 = 0): the elbow branches meet; continuous.
Wrist (q5 = 0): only q4 + q6 is defined, and passing near it the exact q4 must turn fast.
Within ``wrist_band`` (|sin q5| < wrist_band), ``solve_nearest`` moves q4 from its current
value only the share (|sin q5| / wrist_band)² of the way to the exact value (nothing at the
singularity, all of it at the band's edge) and q5, q6 take the rest of the rotation. The
orientation error this leaves is below |sin q5| < wrist_band (rad), about an axis normal to
the flange's z: the wrist centre stays exact, a point at distance L from it moves by ≤ L·error.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

# Numerical slack (m, dimensionless) for poses on the reach boundary or exactly on a singularity.
_BOUNDARY_TOLERANCE = 1e-10
_EXACT_SINGULARITY = 1e-12
_TWO_PI = 2 * math.pi


def _rz(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _rx(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _dot(u, v) -> float:
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


def _wrap(angle):
    """Angle(s) in [−π, π)."""
    return (np.asarray(angle) + math.pi) % _TWO_PI - math.pi


@dataclasses.dataclass
class IkResult:
    """One inverse-kinematics answer.

    q: joint angles (6, rad); the input's reference joints when not reachable.
    reachable: whether q, within the joint limits, puts the flange at the pose (exactly, but
        for the wrist band's orientation error).
    reason: why not reachable ("out of reach", "joint limit joint3", "non-finite pose"), or
        which singularity q is at or near ("shoulder singularity", "wrist singularity": within
        the wrist band, orientation approximate); "" otherwise.
    manipulability: |det J| of the flange's 6×6 geometric Jacobian at q (m³); 0 at a singularity.
    """
    q: np.ndarray
    reachable: bool
    reason: str
    manipulability: float


@dataclasses.dataclass
class RxKinematics:
    """The DH numbers (m), joint limits (rad) and joint speed limits (rad/s) of an RX arm,
    with its forward and inverse kinematics. Defaults are the RX90 (``rx90()``)."""
    d1: float = 0.420      # shoulder height above R
    a2: float = 0.450      # upper arm (J2 → J3)
    d3: float = 0.0        # lateral offset along the J2/J3 axes
    d4: float = 0.450      # forearm (J3 → wrist centre)
    d6: float = 0.085      # wrist centre → flange face
    lower: np.ndarray = dataclasses.field(default_factory=lambda: np.radians([-160, -137.5, -142.5, -270, -105, -270]))
    upper: np.ndarray = dataclasses.field(default_factory=lambda: np.radians([160, 137.5, 142.5, 270, 120, 270]))
    velocity: np.ndarray = dataclasses.field(default_factory=lambda: np.radians([236, 200, 286, 401, 320, 580]))
    wrist_band: float = 0.05  # |sin q5| below which solve_nearest holds q4 back (module notes)

    def __post_init__(self):
        for name in ("lower", "upper", "velocity"):
            setattr(self, name, np.asarray(getattr(self, name), dtype=float).reshape(6))
        if not (self.lower < self.upper).all() or not (self.velocity > 0).all():
            raise ValueError("RxKinematics needs lower < upper and velocity > 0 for every joint")
        self._lower, self._upper = self.lower.tolist(), self.upper.tolist()
        # Joints whose range is not inside [−π, π) reach a position at more than one angle.
        self._multi_turn = [j for j in range(6) if self._lower[j] < -math.pi or self._upper[j] >= math.pi]
        # Fixed parts Rx(α_{i−1})·Tx(a_{i−1}) of each DH row, and the θ offsets.
        alphas = (0.0, -math.pi / 2, 0.0, -math.pi / 2, math.pi / 2, -math.pi / 2)
        self._fixed = [_rx(alpha) for alpha in alphas]
        self._a = (0.0, 0.0, self.a2, 0.0, 0.0, 0.0)
        self._d = (self.d1, 0.0, self.d3, self.d4, 0.0, self.d6)
        self._theta_offset = np.array([0.0, -math.pi / 2, -math.pi / 2, 0.0, 0.0, math.pi])

    @classmethod
    def rx90(cls) -> RxKinematics:
        """Stäubli RX90 (rx90.urdf): SOURCES.md's table, ranges and speeds."""
        return cls()

    @classmethod
    def rx60(cls) -> RxKinematics:
        """Stäubli RX60 (rx60.urdf): SOURCES.md's table, ranges and speeds."""
        return cls(d1=0.341, a2=0.290, d3=0.049, d4=0.310, d6=0.065,
                   lower=[-2.7925, -2.2253, -2.3474, -1.5 * math.pi, -1.9111, -1.5 * math.pi],
                   upper=[2.7925, 2.2253, 2.3474, 1.5 * math.pi, 2.1031, 1.5 * math.pi],
                   velocity=[5.0, 5.0, 5.5, 7.1, 5.5, 12.2])

    def forward(self, q) -> tuple[np.ndarray, np.ndarray]:
        """(R_RF (3, 3), p_RF (3,) in m): the flange's pose in the base at joint angles q (rad)."""
        theta = np.asarray(q, dtype=float) + self._theta_offset
        R, p = np.eye(3), np.zeros(3)
        for Rx_alpha, a, d, angle in zip(self._fixed, self._a, self._d, theta):
            p = p + R @ np.array([a, 0.0, 0.0])
            R = R @ Rx_alpha @ _rz(angle)
            p = p + d * R[:, 2]
        return R, p

    def manipulability(self, q) -> float:
        """|det J| (m³) of the flange's 6×6 geometric Jacobian: |x1·a2·d4·sin q3·sin q5|,
        x1 being the wrist centre's distance from the J1 axis in the arm's plane."""
        q = np.asarray(q, dtype=float)
        x1 = self.a2 * math.sin(q[1]) + self.d4 * math.sin(q[1] + q[2])
        return abs(x1 * self.a2 * self.d4 * math.sin(q[2]) * math.sin(q[4]))

    def _arm_candidates(self, p_C, q_reference):
        """The four (q1, q2, q3) (rad) placing the wrist centre p_C (m, in R): shoulder
        front/back × elbow ±; None if out of reach. Also whether p_C is on the J1 axis,
        where q1 = q_reference[0] (front) or that + π (back)."""
        x, y, z = p_C
        radial_squared = x * x + y * y - self.d3 * self.d3
        z1 = z - self.d1
        cos_q3 = (radial_squared + z1 * z1 - self.a2 ** 2 - self.d4 ** 2) / (2 * self.a2 * self.d4)
        if radial_squared < -_BOUNDARY_TOLERANCE or abs(cos_q3) > 1 + _BOUNDARY_TOLERANCE:
            return None, False
        radial = math.sqrt(max(radial_squared, 0.0))
        q3 = math.acos(min(max(cos_q3, -1.0), 1.0))
        on_axis = math.hypot(x, y) < _EXACT_SINGULARITY
        heading = q_reference[0] if on_axis else math.atan2(y, x)
        candidates = []
        for x1 in (radial, -radial):  # on the axis -radial is -0.0, and atan2 gives the back branch's π
            q1 = heading - math.atan2(self.d3, x1)
            for elbow in (q3, -q3):
                q2 = math.atan2(x1, z1) - math.atan2(self.d4 * math.sin(elbow), self.a2 + self.d4 * math.cos(elbow))
                candidates.append((q1, q2, elbow))
        return candidates, on_axis

    @staticmethod
    def _wrist_candidates(G_columns, q1, q23, q4_reference, band):
        """The two (q4, q5, q6) (rad) for arm angles q1 and q2 + q3, given the columns of
        G = R_RF·Rx(π/2): a solution and its wrist flip (q4 + π, −q5, q6 + π). Where
        |sin q5| < band, q4 moves from q4_reference toward each of the two exact values only
        the share (|sin q5| / band)², and q5, q6 carry the rest of the rotation."""
        c1, s1, c23, s23 = math.cos(q1), math.sin(q1), math.cos(q23), math.sin(q23)
        # Columns of R_03 = Rz(q1)·Rx(−π/2)·Rz(q2 + q3 − π); M = R_03ᵀ·G = Ry(q4)·Rz(q5)·Ry(q6 + π).
        u0, u1, u2 = (-c1 * c23, -s1 * c23, s23), (c1 * s23, s1 * s23, c23), (-s1, c1, 0.0)
        g0, g1, g2 = G_columns
        M01, M21 = _dot(u0, g1), _dot(u2, g1)
        M10, M11, M12 = _dot(u1, g0), _dot(u1, g1), _dot(u1, g2)
        sin_q5 = math.hypot(M01, M21)
        q4 = math.atan2(M21, -M01)
        if sin_q5 >= band:
            q5 = math.atan2(sin_q5, M11)
            q6 = math.atan2(M12, M10) - math.pi
            return (q4, q5, q6), (q4 + math.pi, -q5, q6 + math.pi)
        # Near the singularity: q4 partly held; Rz(q5)·Ry(q6 + π) fitted to N = Ry(−q4)·M
        # (exact where q4 is exact or q5 = 0; the error is below |q5| in between).
        M00, M20, M02, M22 = _dot(u0, g0), _dot(u2, g0), _dot(u0, g2), _dot(u2, g2)
        share = (sin_q5 / band) ** 2
        wrist = []
        for q4_exact in (q4, q4 + math.pi):
            q4_held = q4_reference + share * ((q4_exact - q4_reference + math.pi) % _TWO_PI - math.pi)
            c4, s4 = math.cos(q4_held), math.sin(q4_held)
            q5 = math.atan2(s4 * M21 - c4 * M01, M11)
            q6 = math.atan2(-s4 * M00 - c4 * M20, s4 * M02 + c4 * M22) - math.pi
            wrist.append((q4_held, q5, q6))
        return wrist

    def _arm_branches(self, R_RF, p_RF, q_reference):
        """(the arm's four (q1, q2, q3) or None if out of reach, whether the wrist centre is on
        the J1 axis, the columns of G = R_RF·Rx(π/2)) for the flange at (R_RF, p_RF)."""
        (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = np.asarray(R_RF, dtype=float).tolist()
        x, y, z = np.asarray(p_RF, dtype=float).tolist()
        arm, on_axis = self._arm_candidates((x - self.d6 * r02, y - self.d6 * r12, z - self.d6 * r22), q_reference)
        return arm, on_axis, ((r00, r10, r20), (r02, r12, r22), (-r01, -r11, -r21))

    def _candidates(self, R_RF, p_RF, q_reference, band):
        """All 8 solutions [(q1, …, q6)] (rad, not wrapped), ignoring limits, or None for a
        position out of reach; and whether the wrist centre is on the J1 axis."""
        arm, on_axis, G_columns = self._arm_branches(R_RF, p_RF, q_reference)
        if arm is None:
            return None, False
        candidates = []
        for q1, q2, q3 in arm:
            candidates.extend((q1, q2, q3) + q456
                              for q456 in self._wrist_candidates(G_columns, q1, q2 + q3, q_reference[3], band))
        return candidates, on_axis

    def within_limits(self, q) -> np.ndarray:
        """Whether each row of q (…, 6) lies within the joint limits."""
        q = np.asarray(q)
        return ((q >= self.lower) & (q <= self.upper)).all(axis=-1)

    def solve_all(self, R_RF, p_RF, q_reference=None) -> np.ndarray:
        """Every solution (k, 6) (rad, k ≤ 8) within the joint limits that puts the flange at
        (R_RF, p_RF in m), angles in [−π, π). Joints left free by an exact singularity take
        their value from ``q_reference`` (default 0). Empty (0, 6) if there is none."""
        q_reference = np.zeros(6) if q_reference is None else np.asarray(q_reference, dtype=float)
        candidates, _ = self._candidates(R_RF, p_RF, q_reference, _EXACT_SINGULARITY)
        if candidates is None:
            return np.zeros((0, 6))
        candidates = _wrap(np.array(candidates))
        solutions = candidates[self.within_limits(candidates)]
        distinct = [row for i, row in enumerate(solutions)
                    if not any(np.abs(row - other).max() < 1e-9 for other in solutions[:i])]
        return np.array(distinct).reshape(-1, 6)

    def solve_nearest(self, R_RF, p_RF, q_current) -> IkResult:
        """The solution nearest q_current (6, rad) among all branches and the 2π-equivalents
        of the multi-turn joints (4 and 6) within their limits, for the flange at (R_RF, p_RF in m).
        Near the wrist singularity q4 is held back toward q_current[3] (module notes).
        Not reachable: q = q_current and the reason."""
        q_current = np.asarray(q_current, dtype=float)
        R_RF, p_RF = np.asarray(R_RF, dtype=float), np.asarray(p_RF, dtype=float)
        if not math.isfinite(sum(R_RF.ravel().tolist()) + sum(p_RF.tolist())):
            return IkResult(q_current.copy(), False, "non-finite pose", 0.0)
        arm, on_axis, G_columns = self._arm_branches(R_RF, p_RF, q_current)
        if arm is None:
            return IkResult(q_current.copy(), False, "out of reach", 0.0)
        reference = q_current.tolist()
        # Branch and bound: joints 1–3 alone already cost their share of the distance, so the arm
        # branches are tried nearest first and a branch that cannot beat the best so far is skipped.
        branches = []
        for q123 in arm:
            q = self._feasible_equivalent(q123, reference)
            if q is not None:
                branches.append((sum((a - r) ** 2 for a, r in zip(q, reference)), q123))
        branches.sort(key=lambda branch: branch[0])
        best, best_distance = None, math.inf
        for partial, (q1, q2, q3) in branches:
            if partial >= best_distance:
                break
            for q456 in self._wrist_candidates(G_columns, q1, q2 + q3, reference[3], self.wrist_band):
                q = self._feasible_equivalent((q1, q2, q3) + q456, reference)
                if q is not None:
                    distance = sum((a - r) ** 2 for a, r in zip(q, reference))
                    if distance < best_distance:
                        best, best_distance = q, distance
        if best is None:
            candidates, _ = self._candidates(R_RF, p_RF, q_current, self.wrist_band)
            return IkResult(q_current.copy(), False, self._limit_reason(candidates, reference), 0.0)
        notes = ["shoulder singularity"] if on_axis else []
        if abs(math.sin(best[4])) < self.wrist_band:
            notes.append("wrist singularity")
        return IkResult(np.array(best), True, ", ".join(notes), self.manipulability(best))

    def _feasible_equivalent(self, candidate, reference):
        """The candidate (its first ``len(candidate)`` joints) with each angle wrapped to [−π, π),
        joints 4 and 6 moved to their 2π-equivalent nearest ``reference`` within limits; None if
        a joint is out of its limits."""
        q = []
        for j, angle in enumerate(candidate):
            angle = (angle + math.pi) % _TWO_PI - math.pi
            if j in self._multi_turn:
                angle = _nearest_equivalent(angle, reference[j], self._lower[j], self._upper[j])
            if not self._lower[j] <= angle <= self._upper[j]:
                return None
            q.append(angle)
        return q

    def _limit_reason(self, candidates, reference) -> str:
        """"joint limit jointN[, jointM]": the joints beyond their limits in the candidate
        that violates them least (summed rad)."""
        wrapped = np.array([[_nearest_equivalent(a, r, lo, hi) for a, r, lo, hi in
                             zip(candidate, reference, self._lower, self._upper)] for candidate in candidates])
        violation = np.maximum(self.lower - wrapped, 0) + np.maximum(wrapped - self.upper, 0)
        closest = violation[np.argmin(violation.sum(axis=1))]
        return "joint limit " + ", ".join(f"joint{j + 1}" for j in np.flatnonzero(closest))


def _nearest_equivalent(angle: float, reference: float, lower: float, upper: float) -> float:
    """The angle + 2πk nearest ``reference`` within [lower, upper], or nearest overall
    if none is within (rad)."""
    nearest = angle + _TWO_PI * round((reference - angle) / _TWO_PI)
    if nearest > upper and nearest - _TWO_PI >= lower:
        return nearest - _TWO_PI
    if nearest < lower and nearest + _TWO_PI <= upper:
        return nearest + _TWO_PI
    return nearest
