"""The 12-dof kinematic model of the operator's upper body (thesis Fig. 8.2, Sec. 9.0.1).

Frames: world z up. The body frame B sits on the floor under the hips, x forward (the way
the operator faces), y to the operator's left. q (12,):

    0 base_x, 1 base_y, 2 base_yaw           unicycle base on the floor (Fig. 8.2a)
    3 torso_flexion                          forward lean of the upper body around the hip
    4..7  left arm  (shoulder_flexion, shoulder_abduction, shoulder_rotation, elbow_flexion)
    8..11 right arm (same order)

Geometry (documented choice, the thesis gives none):
    hip height      h = HIP_FRACTION * (torso + neck + LEG_OFFSET) = 0.53 * (torso + neck + 0.75),
                    i.e. ~0.53 of a stature estimated as torso + neck + 0.75 m (standing), or
                    `Segments.hip_height` when it is set (e.g. seated, `human.calibration`)
    torso axis      u = R_z(yaw) R_y(flexion) e_z   (flexion > 0 leans forward)
    thorax          hip + torso * u   (top of the torso segment, at shoulder height)
    head            thorax + neck * u
    shoulders       thorax +/- shoulder_width / 2 along the torso's y axis
    arm (mirror m = +1 left, -1 right), all in the torso frame R_T = R_z(yaw) R_y(flexion):
        R_S = R_y(-flexion) R_x(m abduction) R_z(m rotation)
        elbow  = shoulder + upper_arm * R_T R_S (-e_z)
        wrist  = elbow + forearm * R_T R_S R_y(-elbow_flexion) (-e_z)
    so at q_arm = 0 the arm hangs straight down; shoulder flexion raises it forward,
    abduction raises it sideways (outwards), positive rotation turns the bent forearm
    outwards (external rotation), elbow flexion bends the forearm forward.
"""

from __future__ import annotations

import math

import numpy as np

from hrc_drake.human import _kernels
from hrc_drake.human.config import HIP_HEIGHT_RANGE
from hrc_drake.messages import (
    HEAD,
    L_ELBOW,
    L_SHOULDER,
    L_WRIST,
    R_ELBOW,
    R_SHOULDER,
    R_WRIST,
    THORAX,
)

N_DOF = 12
JOINT_NAMES: tuple[str, ...] = (
    "base_x",
    "base_y",
    "base_yaw",
    "torso_flexion",
    "left_shoulder_flexion",
    "left_shoulder_abduction",
    "left_shoulder_rotation",
    "left_elbow_flexion",
    "right_shoulder_flexion",
    "right_shoulder_abduction",
    "right_shoulder_rotation",
    "right_elbow_flexion",
)
ARM_DOFS = {"left": slice(4, 8), "right": slice(8, 12)}
CAPSULE_NAMES: tuple[str, ...] = (
    "torso",
    "head",
    "left_upper_arm",
    "right_upper_arm",
    "left_forearm",
    "right_forearm",
)

HIP_FRACTION = 0.53
LEG_OFFSET = 0.75
#: hand length beyond the wrist, as a fraction of the forearm length (capsules only)
HAND_FRACTION = 0.37

_BASE_RANGE = 50.0
_ARM_LOWER = np.array([-0.8, -0.5, -1.5, 0.0])
_ARM_UPPER = np.array([3.0, 2.8, 1.5, 2.6])
_MIRROR = {"left": 1.0, "right": -1.0}
_MIRROR_PAIR = np.array([1.0, -1.0])


def _rotation(a, i: int, j: int) -> np.ndarray:
    """Rotation by angle(s) `a` in the (i, j) coordinate plane, shape a.shape + (3, 3)."""
    a = np.asarray(a, dtype=float)
    c, s = np.cos(a), np.sin(a)
    R = np.zeros(a.shape + (3, 3))
    R[..., 0, 0] = R[..., 1, 1] = R[..., 2, 2] = 1.0
    R[..., i, i] = c
    R[..., j, j] = c
    R[..., i, j] = -s
    R[..., j, i] = s
    return R


def _rot_x(a: np.ndarray) -> np.ndarray:
    return _rotation(a, 1, 2)


def _rot_y(a: np.ndarray) -> np.ndarray:
    return _rotation(a, 2, 0)


def _rot_z(a: np.ndarray) -> np.ndarray:
    return _rotation(a, 0, 1)


def _apply(R: np.ndarray, v: np.ndarray) -> np.ndarray:
    return np.einsum("...ij,...j->...i", R, v)


class BodyModel:
    """12-dof upper-body model and its 8 skeletal points (thesis Fig. 8.2 and Fig. 9.1).

    segments: `hrc_drake.human.config.Segments` (torso, neck, shoulder_width, upper_arm,
    forearm in metres), or any object with those attributes; None uses the defaults.
    """

    N_DOF = N_DOF
    JOINT_NAMES = JOINT_NAMES
    ARM_DOFS = ARM_DOFS
    CAPSULE_NAMES = CAPSULE_NAMES

    def __init__(self, segments=None):
        if segments is None:
            from hrc_drake.human.config import Segments

            segments = Segments()
        lengths = {}
        for name in ("torso", "neck", "shoulder_width", "upper_arm", "forearm"):
            value = float(getattr(segments, name))
            if not np.isfinite(value) or value <= 0.0:
                raise ValueError(f"BodyModel: segment length {name}={value!r} must be a positive number (m)")
            lengths[name] = value
        self.segments = segments
        self.torso = lengths["torso"]
        self.neck = lengths["neck"]
        self.shoulder_width = lengths["shoulder_width"]
        self.upper_arm = lengths["upper_arm"]
        self.forearm = lengths["forearm"]
        hip = getattr(segments, "hip_height", 0.0)
        hip = 0.0 if hip is None else float(hip)
        if hip != 0.0 and not (math.isfinite(hip) and HIP_HEIGHT_RANGE[0] <= hip <= HIP_HEIGHT_RANGE[1]):
            raise ValueError(f"BodyModel: hip_height={hip!r} must be 0 (standing) or in "
                             f"{list(HIP_HEIGHT_RANGE)} m")
        # standing: the hip follows the stature; a hip height given (seated) replaces it
        self.hip_height = hip if hip > 0.0 else HIP_FRACTION * (self.torso + self.neck + LEG_OFFSET)
        self.hand_length = HAND_FRACTION * self.forearm
        base_lower = [-_BASE_RANGE, -_BASE_RANGE, -2 * np.pi, -0.3]
        base_upper = [_BASE_RANGE, _BASE_RANGE, 2 * np.pi, 1.2]
        self.q_lower = np.concatenate([base_lower, _ARM_LOWER, _ARM_LOWER])
        self.q_upper = np.concatenate([base_upper, _ARM_UPPER, _ARM_UPPER])
        # capsule radii (m): torso ~ chest half-depth scaled with the shoulders, limbs fixed
        self.capsule_radius = np.array(
            [0.375 * self.shoulder_width, 0.11, 0.06, 0.06, 0.05, 0.05]
        )

    # ------------------------------------------------------------------ poses
    def rest_q(self, base_xy=(0.0, 0.0), yaw: float = 0.0) -> np.ndarray:
        """Standing upright, arms hanging slightly away from the body, elbows slightly bent."""
        base_xy = np.asarray(base_xy, dtype=float).reshape(-1)
        if base_xy.shape != (2,) or not np.all(np.isfinite(base_xy)) or not np.isfinite(yaw):
            raise ValueError(f"rest_q: base_xy must be 2 finite numbers and yaw finite, got {base_xy}, {yaw}")
        arm = np.array([0.1, 0.1, 0.0, 0.3])
        return np.concatenate([base_xy, [float(yaw), 0.0], arm, arm])

    def _check_q(self, q, where: str) -> np.ndarray:
        q = np.asarray(q, dtype=float)
        if q.ndim == 0 or q.shape[-1] != N_DOF:
            raise ValueError(f"{where}: q must have last axis of size {N_DOF}, got shape {q.shape}")
        if not np.all(np.isfinite(q)):
            raise ValueError(f"{where}: q contains NaN or inf")
        return q

    # ------------------------------------------------------------------ kinematics
    def _frames(self, q: np.ndarray):
        """Torso rotation, hip, thorax, torso axis for q (..., 12)."""
        R_torso = _rot_z(q[..., 2]) @ _rot_y(q[..., 3])
        hip = np.stack([q[..., 0], q[..., 1], np.full(q.shape[:-1], self.hip_height)], -1)
        axis = R_torso[..., :, 2]
        thorax = hip + self.torso * axis
        return R_torso, hip, thorax, axis

    def _arm(self, q: np.ndarray, R_torso: np.ndarray, shoulder: np.ndarray, hand: str):
        m = _MIRROR[hand]
        a = q[..., ARM_DOFS[hand]]
        R_upper = R_torso @ _rot_y(-a[..., 0]) @ _rot_x(m * a[..., 1]) @ _rot_z(m * a[..., 2])
        elbow = shoulder - self.upper_arm * R_upper[..., :, 2]
        R_fore = R_upper @ _rot_y(-a[..., 3])
        fore_dir = -R_fore[..., :, 2]
        wrist = elbow + self.forearm * fore_dir
        return elbow, wrist, fore_dir

    def points(self, q) -> np.ndarray:
        """Forward kinematics: the 8 skeletal points (..., 8, 3) for q (..., 12), Fig. 9.1 order."""
        q = self._check_q(q, "BodyModel.points")
        return self._points(q)

    def _points_single(self, q: np.ndarray, with_fore_dir: bool = False):
        """Same as `_points` for one q (12,) with float arithmetic: ~10x faster than numpy calls."""
        x, y, yaw, lean = float(q[0]), float(q[1]), float(q[2]), float(q[3])
        cy, sy, cl, sl = math.cos(yaw), math.sin(yaw), math.cos(lean), math.sin(lean)
        hz = self.hip_height

        def world(px, py, pz, hip=True):
            lx = cl * px + sl * pz
            lz = -sl * px + cl * pz
            if hip:
                return (x + cy * lx - sy * py, y + sy * lx + cy * py, hz + lz)
            return (cy * lx - sy * py, sy * lx + cy * py, lz)

        half = 0.5 * self.shoulder_width
        out = [world(0.0, 0.0, self.torso), world(0.0, 0.0, self.torso + self.neck),
               world(0.0, half, self.torso), world(0.0, -half, self.torso)]
        elbows, wrists, fores = [], [], []
        for m, base in ((1.0, 4), (-1.0, 8)):
            f, ab, r, e = (float(v) for v in q[base:base + 4])
            cf, sf, ca, sa = math.cos(f), math.sin(f), math.cos(ab), math.sin(ab)
            cr, sr, ce, se = math.cos(r), math.sin(r), math.cos(e), math.sin(e)
            msa = m * sa
            ux, uy, uz = sf * ca, msa, -cf * ca
            vx, vy, vz = cr * se, m * sr * se, -ce
            wy = ca * vy - msa * vz
            wz = msa * vy + ca * vz
            fx, fy, fz = cf * vx - sf * wz, wy, sf * vx + cf * wz
            ex, ey, ez = self.upper_arm * ux, m * half + self.upper_arm * uy, self.torso + self.upper_arm * uz
            elbows.append(world(ex, ey, ez))
            wrists.append(world(ex + self.forearm * fx, ey + self.forearm * fy, ez + self.forearm * fz))
            fores.append(world(fx, fy, fz, hip=False))
        pts = np.array(out + elbows + wrists)
        if with_fore_dir:
            return pts, np.array(fores[0]), np.array(fores[1])
        return pts

    def _points(self, q: np.ndarray, with_fore_dir: bool = False):
        if q.ndim == 1:
            if with_fore_dir or type(self)._points_single is not BodyModel._points_single:
                return self._points_single(q, with_fore_dir)
            # `_points_single` compiled (~3 us instead of ~50 us; tested equal)
            dims = np.array([self.hip_height, self.torso, self.neck, 0.5 * self.shoulder_width,
                             self.upper_arm, self.forearm])
            return _kernels.skeleton_points(dims, q)
        # closed-form products of the elementary rotations of the module docstring: a handful
        # of elementwise numpy calls on both arms at once instead of 3x3 matrix products
        c, s = np.cos(q), np.sin(q)
        shape = q.shape[:-1]
        c_arm = c[..., 4:].reshape(shape + (2, 4))
        s_arm = s[..., 4:].reshape(shape + (2, 4))
        cf, ca, cr, ce = (c_arm[..., k] for k in range(4))
        sf, sa, sr, se = (s_arm[..., k] for k in range(4))
        m = _MIRROR_PAIR
        msa = m * sa
        # upper arm and forearm directions in the torso frame, (..., 2) per component
        ux, uy, uz = sf * ca, msa, -cf * ca
        vx, vy, vz = cr * se, m * sr * se, -ce
        wy = ca * vy - msa * vz
        wz = msa * vy + ca * vz
        fx, fy, fz = cf * vx - sf * wz, wy, sf * vx + cf * wz
        half = 0.5 * self.shoulder_width
        top = np.broadcast_to(self.torso, shape)
        zero = np.zeros(shape)
        sh_y = np.stack([np.full(shape, half), np.full(shape, -half)], -1)
        el = (self.upper_arm * ux, sh_y + self.upper_arm * uy, self.torso + self.upper_arm * uz)
        wr = (el[0] + self.forearm * fx, el[1] + self.forearm * fy, el[2] + self.forearm * fz)
        local = [
            np.concatenate([zero[..., None], zero[..., None], np.zeros(shape + (2,)), el[k], wr[k]], -1)
            for k in range(3)
        ]
        local[2][..., 0] = top
        local[2][..., 1] = top + self.neck
        local[1][..., 2:4] = sh_y
        local[2][..., 2:4] = top[..., None]
        pts = self._to_world(local, c[..., 2], s[..., 2], c[..., 3], s[..., 3], q[..., 0], q[..., 1])
        if with_fore_dir:
            fore = self._to_world([fx, fy, fz], c[..., 2], s[..., 2], c[..., 3], s[..., 3], 0.0, 0.0, False)
            return pts, fore[..., 0, :], fore[..., 1, :]
        return pts

    def _to_world(self, local, cy, sy, cl, sl, x, y, add_hip: bool = True) -> np.ndarray:
        """World coordinates (..., K, 3) of torso-frame components local = [x, y, z], each (..., K)."""
        cy, sy, cl, sl = cy[..., None], sy[..., None], cl[..., None], sl[..., None]
        lx = cl * local[0] + sl * local[2]  # R_y(lean)
        lz = -sl * local[0] + cl * local[2]
        wx = cy * lx - sy * local[1]  # R_z(yaw)
        wy = sy * lx + cy * local[1]
        if add_hip:
            wx = wx + np.asarray(x)[..., None]
            wy = wy + np.asarray(y)[..., None]
            lz = lz + self.hip_height
        return np.stack([wx, wy, lz], -1)

    def gaze(self, q, head_yaw_pitch=None) -> np.ndarray:
        """Unit gaze direction (..., 3): the torso's forward axis turned by head yaw, then pitch.

        head_yaw_pitch: (..., 2) head yaw (left positive) and pitch (down positive) relative
        to the torso, or None for straight ahead.
        """
        q = self._check_q(q, "BodyModel.gaze")
        R = _rot_z(q[..., 2]) @ _rot_y(q[..., 3])
        if head_yaw_pitch is not None:
            hyp = np.asarray(head_yaw_pitch, dtype=float)
            if hyp.shape[-1] != 2:
                raise ValueError(f"BodyModel.gaze: head_yaw_pitch must end with size 2, got {hyp.shape}")
            R = R @ _rot_z(hyp[..., 0]) @ _rot_y(hyp[..., 1])
        return R[..., :, 0]

    def capsules(self, q):
        """Body capsules: start (..., 6, 3), end (..., 6, 3), radius (6,) in CAPSULE_NAMES order.

        Torso hip -> thorax, head along the neck axis around the head point, upper arms
        shoulder -> elbow, forearms elbow -> wrist extended by a hand length.
        """
        q = self._check_q(q, "BodyModel.capsules")
        if q.ndim == 1:
            return self.points_and_capsules(q)[1]
        _, hip, thorax, axis = self._frames(q)
        pts, l_dir, r_dir = self._points(q, with_fore_dir=True)
        head = pts[..., HEAD, :]
        start = np.stack(
            [hip, head - 0.06 * axis, pts[..., L_SHOULDER, :], pts[..., R_SHOULDER, :],
             pts[..., L_ELBOW, :], pts[..., R_ELBOW, :]], -2
        )
        end = np.stack(
            [thorax, head + 0.06 * axis, pts[..., L_ELBOW, :], pts[..., R_ELBOW, :],
             pts[..., L_WRIST, :] + self.hand_length * l_dir,
             pts[..., R_WRIST, :] + self.hand_length * r_dir], -2
        )
        return start, end, self.capsule_radius.copy()

    def points_and_capsules(self, q):
        """The 8 points (8, 3) and the capsules (as `capsules`) of one q (12,), from one
        forward-kinematics pass (the torso axis is thorax - hip over the torso length)."""
        q = self._check_q(q, "BodyModel.points_and_capsules")
        if q.ndim != 1:
            raise ValueError(f"BodyModel.points_and_capsules: q must have shape (12,), got {q.shape}")
        pts, l_dir, r_dir = self._points_single(q, with_fore_dir=True)
        hip = np.array([q[0], q[1], self.hip_height])
        thorax = pts[THORAX]
        axis = (thorax - hip) / self.torso
        head = pts[HEAD]
        start = np.array([hip, head - 0.06 * axis, pts[L_SHOULDER], pts[R_SHOULDER],
                          pts[L_ELBOW], pts[R_ELBOW]])
        end = np.array([thorax, head + 0.06 * axis, pts[L_ELBOW], pts[R_ELBOW],
                        pts[L_WRIST] + self.hand_length * l_dir, pts[R_WRIST] + self.hand_length * r_dir])
        return pts, (start, end, self.capsule_radius.copy())

    def capsules_from_points(self, points):
        """Body capsules (CAPSULE_NAMES order) from the 8 skeleton points, e.g. of a recorded frame.

        The torso hangs `torso` m below the thorax along world -z; the head capsule lies along
        thorax -> head; forearms are extended beyond the wrist by a hand length.
        """
        pts = np.asarray(points, dtype=float).reshape(8, 3)
        return self._capsules_from_points_floats(pts)  # 10 us, the numpy form 26 us

    def _capsules_from_points_numpy(self, pts):
        """`capsules_from_points` in numpy: the reference of `_capsules_from_points_floats`."""
        up = np.array([0.0, 0.0, 1.0])
        neck = pts[HEAD] - pts[THORAX]
        neck_dir = neck / max(np.linalg.norm(neck), 1e-9)
        fore = pts[[L_WRIST, R_WRIST]] - pts[[L_ELBOW, R_ELBOW]]
        fore_dir = fore / np.maximum(np.linalg.norm(fore, axis=1, keepdims=True), 1e-9)
        start = np.stack([pts[THORAX] - self.torso * up, pts[HEAD] - 0.06 * neck_dir, pts[L_SHOULDER],
                          pts[R_SHOULDER], pts[L_ELBOW], pts[R_ELBOW]])
        hands = pts[[L_WRIST, R_WRIST]] + self.hand_length * fore_dir
        end = np.stack(
            [pts[THORAX], pts[HEAD] + 0.06 * neck_dir, pts[L_ELBOW], pts[R_ELBOW], hands[0], hands[1]]
        )
        return start, end, self.capsule_radius.copy()

    def _capsules_from_points_floats(self, pts):
        """`capsules_from_points` with float arithmetic, the numpy form's operations in its order
        (the neck's length by numpy's norm, as there)."""
        rows = pts.tolist()
        thorax, head = rows[THORAX], rows[HEAD]
        neck = [head[c] - thorax[c] for c in range(3)]
        scale = max(float(np.linalg.norm(pts[HEAD] - pts[THORAX])), 1e-9)
        neck_dir = [x / scale for x in neck]
        hands = []
        for elbow, wrist in ((rows[L_ELBOW], rows[L_WRIST]), (rows[R_ELBOW], rows[R_WRIST])):
            fore = [wrist[c] - elbow[c] for c in range(3)]
            length = max(math.sqrt(fore[0] * fore[0] + fore[1] * fore[1] + fore[2] * fore[2]), 1e-9)
            hands.append([wrist[c] + self.hand_length * (fore[c] / length) for c in range(3)])
        hip = [thorax[0] - self.torso * 0.0, thorax[1] - self.torso * 0.0, thorax[2] - self.torso * 1.0]
        start = np.array([hip, [head[c] - 0.06 * neck_dir[c] for c in range(3)], rows[L_SHOULDER],
                          rows[R_SHOULDER], rows[L_ELBOW], rows[R_ELBOW]])
        end = np.array([thorax, [head[c] + 0.06 * neck_dir[c] for c in range(3)], rows[L_ELBOW],
                        rows[R_ELBOW], hands[0], hands[1]])
        return start, end, self.capsule_radius.copy()

    # ------------------------------------------------------------------ inverse kinematics
    def _clip(self, q: np.ndarray) -> np.ndarray:
        span = self.q_upper - self.q_lower
        return np.clip(q, self.q_lower + 1e-6 * span, self.q_upper - 1e-6 * span)

    def _arm_closed_form(self, R_torso, shoulder, elbow, wrist, hand: str):
        """Closed-form arm angles from shoulder, elbow, wrist positions (None if degenerate)."""
        m = _MIRROR[hand]
        d_upper = R_torso.T @ (elbow - shoulder)
        n = np.linalg.norm(d_upper)
        if n < 1e-9:
            return None
        d = d_upper / n
        # d = R_y(-f) R_x(m a) (-e_z) = (sin f cos a, m sin a, -cos f cos a)
        abduction = np.arcsin(np.clip(m * d[1], -1.0, 1.0))
        flexion = np.arctan2(d[0], -d[2])
        if wrist is None:
            return np.array([flexion, abduction, 0.0, 0.3])
        d_fore = wrist - elbow
        nf = np.linalg.norm(d_fore)
        if nf < 1e-9:
            return np.array([flexion, abduction, 0.0, 0.3])
        R_upper0 = _rot_y(np.array(-flexion)) @ _rot_x(np.array(m * abduction))
        v = R_upper0.T @ (R_torso.T @ d_fore) / nf
        # v = R_z(m r) R_y(-e) (-e_z) = (cos(m r) sin e, sin(m r) sin e, -cos e)
        elbow_flexion = np.arccos(np.clip(-v[2], -1.0, 1.0))
        rotation = m * np.arctan2(v[1], v[0]) if np.hypot(v[0], v[1]) > 1e-6 else 0.0
        return np.array([flexion, abduction, rotation, elbow_flexion])

    def _initial_guess(self, pts: np.ndarray, finite: np.ndarray, q_ref: np.ndarray) -> np.ndarray:
        """Closed-form pose from the visible points, falling back on q_ref where they are missing."""
        q = q_ref.copy()
        yaw = q[2]
        if finite[L_SHOULDER] and finite[R_SHOULDER]:
            lateral = pts[L_SHOULDER] - pts[R_SHOULDER]
            yaw = np.arctan2(-lateral[0], lateral[1])
            yaw = q_ref[2] + (yaw - q_ref[2] + np.pi) % (2 * np.pi) - np.pi  # nearest to reference
        q[2] = yaw
        thorax = None
        if finite[THORAX]:
            thorax = pts[THORAX]
        elif finite[L_SHOULDER] and finite[R_SHOULDER]:
            thorax = 0.5 * (pts[L_SHOULDER] + pts[R_SHOULDER])
        if thorax is not None:
            flexion = np.arccos(np.clip((thorax[2] - self.hip_height) / self.torso, -1.0, 1.0))
            if finite[HEAD]:
                up = pts[HEAD] - thorax
                forward = up[0] * np.cos(yaw) + up[1] * np.sin(yaw)
                flexion = np.arctan2(forward, up[2])
            q[3] = flexion
            lean = self.torso * np.sin(flexion)
            q[0] = thorax[0] - lean * np.cos(yaw)
            q[1] = thorax[1] - lean * np.sin(yaw)
        q = self._clip(q)
        R_torso = _rot_z(np.array(q[2])) @ _rot_y(np.array(q[3]))
        model_pts = self._points(q)
        chains = (("left", L_SHOULDER, L_ELBOW, L_WRIST), ("right", R_SHOULDER, R_ELBOW, R_WRIST))
        for hand, sh, el, wr in chains:
            if not finite[el]:
                continue
            shoulder = pts[sh] if finite[sh] else model_pts[sh]
            arm = self._arm_closed_form(R_torso, shoulder, pts[el], pts[wr] if finite[wr] else None, hand)
            if arm is not None:
                q[ARM_DOFS[hand]] = arm
        return self._clip(q)

    def inverse(self, points, q0=None, regularization: float = 1e-3) -> np.ndarray:
        """Least-squares inverse kinematics from the 8 skeletal points (thesis 8.1.1, ref. [134]).

        Minimises sum ||FK_i(q) - p_i||^2 over the finite rows of `points` (8, 3) plus a small
        `regularization`^2 ||q - q_init||^2 that keeps unseen joints near the initial guess;
        q stays within [q_lower, q_upper]. The initial guess is solved in closed form from the
        visible points, completed by q0 (or the rest pose) where points are missing.
        """
        pts = np.asarray(points, dtype=float)
        if pts.shape != (8, 3):
            raise ValueError(f"BodyModel.inverse: points must have shape (8, 3), got {pts.shape}")
        finite = np.all(np.isfinite(pts), axis=1)
        if finite.sum() < 3:
            raise ValueError(
                f"BodyModel.inverse: need at least 3 finite skeletal points, got {int(finite.sum())}"
            )
        if q0 is None:
            centre = pts[finite].mean(axis=0)
            q_ref = self.rest_q(centre[:2], 0.0)
        else:
            q_ref = self._check_q(q0, "BodyModel.inverse(q0)").reshape(N_DOF).copy()
        q_init = self._initial_guess(pts, finite, self._clip(q_ref))
        target = pts[finite]

        def residual(q):
            err = (self._points(q)[finite] - target).ravel()
            return np.concatenate([err, regularization * (q - q_init)])

        from scipy.optimize import least_squares  # lazily: scipy.optimize costs ~1 s to import

        result = least_squares(
            residual, q_init, bounds=(self.q_lower, self.q_upper), method="trf", x_scale=1.0,
            xtol=1e-10, ftol=1e-10, gtol=1e-10, max_nfev=200,
        )
        return result.x
