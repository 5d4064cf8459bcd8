"""Closed-form kinematics of the Stäubli RX90 / RX60 (6R, spherical wrist); the inverse in compiled kernels.

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

The inverse is a set of kernels (``compiled``): ``nearest_solution`` is what a tick runs (through
``slave_inverse_kinematics.ik_step``), ``solve_nearest`` and ``solve_all`` wrap it and its helpers for
callers that want an ``IkResult`` or every solution. A kernel answers with a status of bit flags
(``NON_FINITE`` … ``WRIST_SINGULARITY``, the joints a ``JOINT_LIMIT`` names above them);
``status_reason`` words it.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from heft.systems.compiled import compiled, float_array

# Numerical slack (m, dimensionless) for poses on the reach boundary or exactly on a singularity.
_BOUNDARY_TOLERANCE = 1e-10
_EXACT_SINGULARITY = 1e-12
_TWO_PI = 2 * math.pi

# The status a kernel returns: bit flags. Unreachable (any of the first three): q is the reference.
NON_FINITE = 1             # the pose has a NaN or an infinity (or is not a pose at all)
OUT_OF_REACH = 2           # the wrist centre is beyond the arm's reach
JOINT_LIMIT = 4            # every solution has a joint beyond its limits; which: ``limit_joints``
UNREACHABLE = NON_FINITE | OUT_OF_REACH | JOINT_LIMIT
SHOULDER_SINGULARITY = 8   # reachable, the wrist centre on the J1 axis (q1 kept from the reference)
WRIST_SINGULARITY = 16     # reachable, |sin q5| < the wrist band (orientation approximate)
_LIMIT_JOINTS = 5          # bit 5 + j: joint j + 1 is beyond its limits (with JOINT_LIMIT)

WORK_ROWS = 16
"""Rows of the (WORK_ROWS, 6) scratch ``nearest_solution`` and ``solve_all``'s kernel write."""
_ARM, _WRIST, _TRIAL, _BEST, _CANDIDATES = 0, 4, 6, 7, 8  # the scratch's rows: 4, 2, 1, 1, 8


def _rz(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _rx(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


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


def limit_joints(status: int) -> list[int]:
    """The joints (1–6) a ``JOINT_LIMIT`` status names."""
    return [j + 1 for j in range(6) if status >> (_LIMIT_JOINTS + j) & 1]


def status_reason(status: int) -> str:
    """``IkResult.reason`` for a kernel's status."""
    if status & NON_FINITE:
        return "non-finite pose"
    if status & OUT_OF_REACH:
        return "out of reach"
    if status & JOINT_LIMIT:
        return "joint limit " + ", ".join(f"joint{j}" for j in limit_joints(status))
    notes = (["shoulder singularity"] if status & SHOULDER_SINGULARITY else []) + (
        ["wrist singularity"] if status & WRIST_SINGULARITY else [])
    return ", ".join(notes)


@dataclasses.dataclass
class RxKinematics:
    """The DH numbers (m), joint limits (rad) and joint speed limits (rad/s) of an RX arm,
    with its forward and inverse kinematics. Defaults are the RX90 (``rx90()``).
    ``dh`` (5): [d1, a2, d3, d4, d6], the lengths as the kernels take them."""
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
            setattr(self, name, np.array(getattr(self, name), dtype=float).reshape(6))
        if not (self.lower < self.upper).all() or not (self.velocity > 0).all():
            raise ValueError("RxKinematics needs lower < upper and velocity > 0 for every joint")
        self.wrist_band = float(self.wrist_band)
        self.dh = np.array([self.d1, self.a2, self.d3, self.d4, self.d6], dtype=float)
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

    def within_limits(self, q) -> np.ndarray:
        """Whether each row of q (…, 6) lies within the joint limits."""
        q = np.asarray(q)
        return ((q >= self.lower) & (q <= self.upper)).all(axis=-1)

    def solve_all(self, R_RF, p_RF, q_reference=None) -> np.ndarray:
        """Every solution (k, 6) (rad, k ≤ 8) within the joint limits that puts the flange at
        (R_RF, p_RF in m), angles in [−π, π). Joints left free by an exact singularity take
        their value from ``q_reference`` (default 0). Empty (0, 6) if there is none."""
        R_RF, p_RF, q_reference = _checked(R_RF, p_RF, np.zeros(6) if q_reference is None else q_reference)
        solutions = np.empty((8, 6))
        count = all_solutions(self.dh, self.lower, self.upper, R_RF, p_RF, q_reference, solutions,
                              np.empty((WORK_ROWS, 6)))
        return solutions[:count]

    def solve_nearest(self, R_RF, p_RF, q_current) -> IkResult:
        """The solution nearest q_current (6, rad) among all branches and the 2π-equivalents
        of the multi-turn joints (4 and 6) within their limits, for the flange at (R_RF, p_RF in m)
        (``nearest_solution``). Near the wrist singularity q4 is held back toward q_current[3]
        (module notes). Not reachable: q = q_current and the reason."""
        R_RF, p_RF, q_current = _checked(R_RF, p_RF, q_current)
        q = np.empty(6)
        status = nearest_solution(self.dh, self.lower, self.upper, self.wrist_band, R_RF, p_RF, q_current, q,
                                  np.empty((WORK_ROWS, 6)))
        reachable = not status & UNREACHABLE
        return IkResult(q, reachable, status_reason(status), self.manipulability(q) if reachable else 0.0)


def _checked(R_RF, p_RF, q):
    """The arguments as the kernels take them, or a ValueError naming the one of the wrong shape."""
    R_RF, p_RF, q = float_array(R_RF), float_array(p_RF), float_array(q)
    for name, value, shape in (("R_RF", R_RF, (3, 3)), ("p_RF", p_RF, (3,)), ("the joint reference", q, (6,))):
        if value.shape != shape:
            raise ValueError(f"{name} must have the shape {shape}; got {value.shape}")
    return R_RF, p_RF, q


# --- kernels -----------------------------------------------------------------------------------

@compiled("float64(float64)")
def wrapped(angle):
    """The angle in [−π, π) (rad)."""
    return (angle + math.pi) % _TWO_PI - math.pi


@compiled("float64(float64, float64, float64, float64)")
def nearest_equivalent(angle, reference, lower, upper):
    """The angle + 2πk nearest ``reference`` within [lower, upper], or nearest overall
    if none is within (rad)."""
    nearest = angle + _TWO_PI * round((reference - angle) / _TWO_PI)
    if nearest > upper and nearest - _TWO_PI >= lower:
        return nearest - _TWO_PI
    if nearest < lower and nearest + _TWO_PI <= upper:
        return nearest + _TWO_PI
    return nearest


@compiled("int64(float64[:], float64[:, :], float64[:], float64, float64[:, :])")
def _arm_branches(dh, R, p, q1_reference, arm):
    """Writes into arm[:, :3] the four (q1, q2, q3) (rad) placing the wrist centre of the flange at
    (R, p (m)): shoulder front/back × elbow ±. Returns OUT_OF_REACH (arm untouched), or
    SHOULDER_SINGULARITY where the wrist centre is on the J1 axis and q1 = q1_reference (front)
    or that + π (back), else 0."""
    d1, a2, d3, d4, d6 = dh[0], dh[1], dh[2], dh[3], dh[4]
    x, y, z = p[0] - d6 * R[0, 2], p[1] - d6 * R[1, 2], p[2] - d6 * R[2, 2]
    radial_squared = x * x + y * y - d3 * d3
    z1 = z - d1
    cos_q3 = (radial_squared + z1 * z1 - a2 ** 2 - d4 ** 2) / (2 * a2 * d4)
    if radial_squared < -_BOUNDARY_TOLERANCE or abs(cos_q3) > 1 + _BOUNDARY_TOLERANCE:
        return OUT_OF_REACH
    radial = math.sqrt(max(radial_squared, 0.0))
    q3 = math.acos(min(max(cos_q3, -1.0), 1.0))
    on_axis = math.hypot(x, y) < _EXACT_SINGULARITY
    heading = q1_reference if on_axis else math.atan2(y, x)
    row = 0
    for x1 in (radial, -radial):  # on the axis -radial is -0.0, and atan2 gives the back branch's π
        q1 = heading - math.atan2(d3, x1)
        for elbow in (q3, -q3):
            arm[row, 0] = q1
            arm[row, 1] = math.atan2(x1, z1) - math.atan2(d4 * math.sin(elbow), a2 + d4 * math.cos(elbow))
            arm[row, 2] = elbow
            row += 1
    return SHOULDER_SINGULARITY if on_axis else 0


@compiled("void(float64[:, :], float64, float64, float64, float64, float64[:, :])")
def _wrist_pair(R, q1, q23, q4_reference, band, wrist):
    """Writes into wrist (2, 3) the two (q4, q5, q6) (rad) for arm angles q1 and q2 + q3 and the
    flange's orientation R = R_RF: a solution and its wrist flip (q4 + π, −q5, q6 + π). Where
    |sin q5| < band, q4 moves from q4_reference toward each of the two exact values only
    the share (|sin q5| / band)², and q5, q6 carry the rest of the rotation."""
    c1, s1, c23, s23 = math.cos(q1), math.sin(q1), math.cos(q23), math.sin(q23)
    # M = R_03ᵀ·G = Ry(q4)·Rz(q5)·Ry(q6 + π), G = R_RF·Rx(π/2) (columns R[:, 0], R[:, 2], −R[:, 1]),
    # R_03 = Rz(q1)·Rx(−π/2)·Rz(q2 + q3 − π) (columns u0, u1, u2); M_ij = u_i·g_j.
    u00, u01, u02 = -c1 * c23, -s1 * c23, s23
    u10, u11, u12 = c1 * s23, s1 * s23, c23
    u20, u21, u22 = -s1, c1, 0.0
    g00, g01, g02 = R[0, 0], R[1, 0], R[2, 0]
    g10, g11, g12 = R[0, 2], R[1, 2], R[2, 2]
    g20, g21, g22 = -R[0, 1], -R[1, 1], -R[2, 1]
    M01 = u00 * g10 + u01 * g11 + u02 * g12
    M21 = u20 * g10 + u21 * g11 + u22 * g12
    M10 = u10 * g00 + u11 * g01 + u12 * g02
    M11 = u10 * g10 + u11 * g11 + u12 * g12
    M12 = u10 * g20 + u11 * g21 + u12 * g22
    sin_q5 = math.hypot(M01, M21)
    q4 = math.atan2(M21, -M01)
    if sin_q5 >= band:
        q5 = math.atan2(sin_q5, M11)
        q6 = math.atan2(M12, M10) - math.pi
        wrist[0, 0], wrist[0, 1], wrist[0, 2] = q4, q5, q6
        wrist[1, 0], wrist[1, 1], wrist[1, 2] = q4 + math.pi, -q5, q6 + math.pi
        return
    # Near the singularity: q4 partly held; Rz(q5)·Ry(q6 + π) fitted to N = Ry(−q4)·M
    # (exact where q4 is exact or q5 = 0; the error is below |q5| in between).
    M00 = u00 * g00 + u01 * g01 + u02 * g02
    M20 = u20 * g00 + u21 * g01 + u22 * g02
    M02 = u00 * g20 + u01 * g21 + u02 * g22
    M22 = u20 * g20 + u21 * g21 + u22 * g22
    share = (sin_q5 / band) ** 2
    row = 0
    for q4_exact in (q4, q4 + math.pi):
        q4_held = q4_reference + share * wrapped(q4_exact - q4_reference)
        c4, s4 = math.cos(q4_held), math.sin(q4_held)
        wrist[row, 0] = q4_held
        wrist[row, 1] = math.atan2(s4 * M21 - c4 * M01, M11)
        wrist[row, 2] = math.atan2(-s4 * M00 - c4 * M20, s4 * M02 + c4 * M22) - math.pi
        row += 1


@compiled("int64(float64[:], float64, float64[:, :], float64[:], float64[:], float64[:, :], float64[:, :])")
def _candidates(dh, band, R, p, q_reference, arm, candidates):
    """Writes into candidates (8, 6) all 8 solutions (rad, not wrapped), ignoring limits, for the
    flange at (R, p (m)), arm (4, ≥ 3) being scratch; returns ``_arm_branches``'s status."""
    status = _arm_branches(dh, R, p, q_reference[0], arm)
    if status & OUT_OF_REACH:
        return status
    for i in range(4):
        _wrist_pair(R, arm[i, 0], arm[i, 1] + arm[i, 2], q_reference[3], band, candidates[2 * i:2 * i + 2, 3:6])
        for k in range(2 * i, 2 * i + 2):
            candidates[k, 0], candidates[k, 1], candidates[k, 2] = arm[i, 0], arm[i, 1], arm[i, 2]
    return status


@compiled("boolean(float64[:], int64, float64[:], float64[:], float64[:], float64[:])")
def _feasible_equivalent(candidate, n, reference, lower, upper, q):
    """Writes into q[:n] the candidate's first n joints wrapped to [−π, π), the joints whose range
    exceeds that (multi-turn: 4 and 6) moved to their 2π-equivalent nearest ``reference`` within
    limits; returns whether every one is within its limits (q may be the candidate itself)."""
    for j in range(n):
        angle = wrapped(candidate[j])
        if lower[j] < -math.pi or upper[j] >= math.pi:
            angle = nearest_equivalent(angle, reference[j], lower[j], upper[j])
        if not lower[j] <= angle <= upper[j]:
            return False
        q[j] = angle
    return True


@compiled("float64(float64[:], float64[:], int64)")
def _squared_distance(q, reference, n):
    """Σ (q_j − reference_j)² over the first n joints (rad²)."""
    total = 0.0
    for j in range(n):
        total += (q[j] - reference[j]) ** 2
    return total


@compiled("int64(float64[:, :], float64[:], float64[:], float64[:])")
def _limit_joints(candidates, reference, lower, upper):
    """JOINT_LIMIT with the bits of the joints beyond their limits in the candidate (of 8, each
    joint at its 2π-equivalent nearest ``reference``) that violates them least (summed rad)."""
    least, status = math.inf, JOINT_LIMIT
    for k in range(8):
        total, joints = 0.0, JOINT_LIMIT
        for j in range(6):
            angle = nearest_equivalent(candidates[k, j], reference[j], lower[j], upper[j])
            violation = max(lower[j] - angle, 0.0) + max(angle - upper[j], 0.0)
            total += violation
            if violation != 0.0:
                joints |= 1 << (_LIMIT_JOINTS + j)
        if total < least:
            least, status = total, joints
    return status


@compiled("int64(float64[:], float64[:], float64[:], float64, float64[:, :], float64[:], float64[:], float64[:], "
          "float64[:, :])")
def nearest_solution(dh, lower, upper, band, R, p, q_reference, q, work):
    """Writes into q (6, rad) the solution nearest q_reference (Euclidean, rad) for the flange at
    (R = R_RF, p = p_RF (m)) among all branches and the 2π-equivalents of the multi-turn joints
    within the limits [lower, upper]; for the arm ``dh`` (``RxKinematics.dh``) and the wrist band
    ``band``. Returns the status (module notes); unreachable: q = q_reference. ``work``
    (``WORK_ROWS``, 6): scratch. q may be q_reference itself."""
    if not math.isfinite((R[0, 0] + R[0, 1] + R[0, 2] + R[1, 0] + R[1, 1] + R[1, 2] + R[2, 0] + R[2, 1] + R[2, 2])
                         + (p[0] + p[1] + p[2])):
        status = NON_FINITE
    else:
        status = _arm_branches(dh, R, p, q_reference[0], work[_ARM:_ARM + 4])
    if status & UNREACHABLE:
        for j in range(6):
            q[j] = q_reference[j]
        return status
    arm, wrist, trial, best = work[_ARM:_ARM + 4], work[_WRIST:_WRIST + 2], work[_TRIAL], work[_BEST]
    # Branch and bound: joints 1–3 alone already cost their share of the distance, so the arm
    # branches are tried nearest first and a branch that cannot beat the best so far is skipped.
    for i in range(4):  # arm[i, 3]: the branch's share, ∞ when beyond a limit (or tried)
        feasible = _feasible_equivalent(arm[i], 3, q_reference, lower, upper, trial)
        arm[i, 3] = _squared_distance(trial, q_reference, 3) if feasible else math.inf
    best_distance, found = math.inf, False
    for _ in range(4):
        nearest = -1  # the untried branch with the least share, the first of equals (a stable sort's order)
        for i in range(4):
            if arm[i, 3] < math.inf and (nearest < 0 or arm[i, 3] < arm[nearest, 3]):
                nearest = i
        if nearest < 0 or arm[nearest, 3] >= best_distance:
            break
        arm[nearest, 3] = math.inf
        _wrist_pair(R, arm[nearest, 0], arm[nearest, 1] + arm[nearest, 2], q_reference[3], band, wrist)
        for k in range(2):
            trial[0], trial[1], trial[2] = arm[nearest, 0], arm[nearest, 1], arm[nearest, 2]
            trial[3], trial[4], trial[5] = wrist[k, 0], wrist[k, 1], wrist[k, 2]
            if _feasible_equivalent(trial, 6, q_reference, lower, upper, trial):
                distance = _squared_distance(trial, q_reference, 6)
                if distance < best_distance:
                    best_distance, found = distance, True
                    best[:] = trial
    if not found:
        candidates = work[_CANDIDATES:_CANDIDATES + 8]
        _candidates(dh, band, R, p, q_reference, arm, candidates)
        status = _limit_joints(candidates, q_reference, lower, upper)
        for j in range(6):
            q[j] = q_reference[j]
        return status
    if abs(math.sin(best[4])) < band:
        status |= WRIST_SINGULARITY
    q[:] = best
    return status


@compiled("int64(float64[:], float64[:], float64[:], float64[:, :], float64[:], float64[:], float64[:, :], "
          "float64[:, :])")
def all_solutions(dh, lower, upper, R, p, q_reference, solutions, work):
    """Writes into solutions (8, 6) every distinct solution (rad, in [−π, π)) within the limits for
    the flange at (R, p (m)), joints left free by an exact singularity taken from q_reference;
    returns how many (0 out of reach). ``work`` (``WORK_ROWS``, 6): scratch."""
    candidates = work[_CANDIDATES:_CANDIDATES + 8]
    if _candidates(dh, _EXACT_SINGULARITY, R, p, q_reference, work[_ARM:_ARM + 4], candidates) & OUT_OF_REACH:
        return 0
    kept = 0  # the candidates within the limits, wrapped, moved to the front
    for k in range(8):
        within = True
        for j in range(6):
            candidates[kept, j] = wrapped(candidates[k, j])
            within = within and lower[j] <= candidates[kept, j] <= upper[j]
        if within:
            kept += 1
    count = 0
    for k in range(kept):
        distinct = True
        for other in range(k):
            difference = 0.0
            for j in range(6):
                difference = max(difference, abs(candidates[k, j] - candidates[other, j]))
            distinct = distinct and not difference < 1e-9
        if distinct:
            solutions[count] = candidates[k]
            count += 1
    return count
