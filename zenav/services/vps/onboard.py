"""The robot's pose from the field's tags a camera on it sees (PhotonVision's pipelines, on a robot that stays level).

Pure. Every detected tag of the [field] layout gives four 3D-2D correspondences (its corners on the field, where
the lens shows them). Several tags at once are solved jointly (MultiTag: SQPnP over all their corners); one tag by
IPPE, which gives two poses, the tag's two-fold ambiguity. Each candidate becomes a robot pose on the floor (x, y,
heading) and is refined there by Gauss-Newton on the corners' reprojection with the camera's mount on the robot
held to the config: a wrong flip, which tilts the camera, then fits far worse than the right one. A realistic
camera's pitch, the tags' print scale and each tag's place are solved beside it, held near the config by priors of
their error sizes ([onboard_camera]), so the covariance carries them (the tags stand near the camera's height, where
a few mm say much about the distance). A one-tag fix is kept when the better candidate's reprojection error is at
most `max_ambiguity` of the worse's; otherwise only the
current estimate can tell them apart, and it must be clearly nearer one of them. The covariance is the
least-squares one, corner_sigma^2 (J^T J)^-1: it grows with the tags' distance and shrinks with their number;
`widen` adds the lens's calibration error and the heading's turn, which the corners cannot show.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from zenav.common.config import FieldTag
from zenav.common.fieldtags import rotation
from zenav.common.geometry import wrap_angle
from zenav.common.onboardcam import OnboardCamera
from zenav.services.vps.detect import Tag
from zenav.world.onboard import CAMERA_AXES, lens, mount, robot_to_camera

ITERATIONS = 8  # Gauss-Newton steps of the floor refinement, at most
STEP_DONE = 1e-6  # [m, rad] a step this small ends it (the next would move the pose by under a micrometre)
SAME = (0.01, 0.01)  # [m, rad] two refined candidates this close are one pose (no ambiguity left) ...
SAME_D2 = 9.0  # ... and so are two within 3 sigma of the fix's covariance (Mahalanobis d^2)
PRIOR_GATE = (0.3, 0.3)  # [m, rad] the estimate chooses a candidate only when it lies this near it ...
PRIOR_MARGIN = 3.0  # ... and the other candidate is this many times farther
MAX_TILT_OFF = 0.1  # [m] a PnP solution whose camera stands this far off its mounted height is no pose on the floor
VAR_FLOOR = (1e-6, 1e-6, 1e-6)  # [m^2, m^2, rad^2] least variances (the model's own errors)
PRIOR_LEAST = 1e-6  # [rad, m] a nuisance's prior no tighter than this (an error size of 0 holds it there)


@dataclass(frozen=True)
class TagFix:
    """The robot's pose from one frame's tags."""

    x: float  # [m] map frame
    y: float  # [m]
    theta: float  # [rad]
    cov: tuple[float, ...]  # 3x3 row-major: x, y [m^2], theta [rad^2]
    tags: tuple[int, ...]  # ids solved over
    distance: float  # [m] mean camera-to-tag distance
    rms_px: float  # [px] corners' reprojection error
    ambiguity: float = 0.0  # one tag: better candidate's error / worse's (0: several tags, or one pose left)
    chosen_by_estimate: bool = False  # one ambiguous tag whose candidate the current estimate picked
    row: float = 0.0  # [px] the tags' corners' mean image row (a rolling shutter exposed them then)


@dataclass(frozen=True)
class Refused:
    """Why a frame's tags gave no fix."""

    reason: str  # ambiguous, too_far, off_floor, no_solution
    detail: str


def solve(
    found: Sequence[Tag],
    layout: Mapping[int, FieldTag],
    cfg: OnboardCamera,
    estimate: tuple[float, float, float] | None = None,  # [m, m, rad] the current pose estimate, if any
) -> TagFix | Refused | None:
    """The robot's pose from the layout's tags among `found`; None when none of them is in the layout."""
    known = [t for t in found if t.id in layout]
    if not known:
        return None
    world = np.concatenate([layout[t.id].corners() for t in known])
    image = np.concatenate([t.corners for t in known]).astype(np.float64)
    distance = _distance(known, layout, cfg, image)
    if len(known) == 1 and distance > cfg.max_distance:
        return Refused("too_far", f"one tag ({known[0].id}) {distance:.2f} m away, beyond max_distance {cfg.max_distance:g} m")
    seeds = _candidates(known, layout, cfg, world, image)
    if not seeds:
        return Refused("no_solution", f"no PnP solution places the camera on its mount over tags {[t.id for t in known]}")
    p = _problem(cfg, world, image, nuisance(cfg, len(known)))
    refined = sorted(_outcomes(p, _refine(p, seeds)), key=lambda r: r[1])
    ids = tuple(t.id for t in known)
    best, err, j = refined[0]
    cov = _covariance(cfg, j)
    rest = [r for r in refined[1:] if not _same(best, r[0], cov)]  # the other minima (seeds that converged apart)
    ambiguity = 0.0
    chosen = False
    if len(known) == 1 and rest:
        other, err2, j2 = rest[0]
        ambiguity = err / max(err2, 1e-12)
        if ambiguity > cfg.max_ambiguity:
            pick = _by_estimate(best, other, estimate)
            if pick is None:
                why = "no estimate to choose by" if estimate is None else "the estimate is near neither, or near both"
                return Refused("ambiguous", f"tag {ids[0]}: its two poses fit alike (ambiguity {ambiguity:.2f}); {why}")
            if pick is other:
                best, err, cov = other, err2, _covariance(cfg, j2)
            chosen = True
    return TagFix(*best, widen(cfg, cov), ids, distance, err, ambiguity, chosen, float(image[:, 1].mean()))


def widen(cfg: OnboardCamera, cov: tuple[float, ...]) -> tuple[float, ...]:
    """A fix's covariance (3x3 row-major) with what its nuisances do not carry: the lens off its calibration
    (calibration_error px beside corner_sigma on every corner) and, on the heading, the mount's and the chassis' turn
    (mount_tilt, vibration). An `ideal` camera's is unchanged."""
    if cfg.model == "ideal":
        return cov
    c = np.array(cov, dtype=np.float64).reshape(3, 3) - np.diag(VAR_FLOOR)
    c = c * (1.0 + (cfg.calibration_error / cfg.corner_sigma) ** 2) + np.diag(VAR_FLOOR)
    c[2, 2] += cfg.mount_tilt**2 + cfg.vibration**2
    return tuple(float(v) for v in c.ravel())


def _distance(known: Sequence[Tag], layout: Mapping[int, FieldTag], cfg: OnboardCamera, image: np.ndarray) -> float:
    """[m] the mean camera-to-tag distance, from each tag's size in pixels (before any pose is solved)."""
    f = math.sqrt(cfg.fx * cfg.fy)
    out = []
    for t in known:
        side = float(np.mean(np.linalg.norm(np.roll(t.corners, -1, axis=0) - t.corners, axis=1)))
        out.append(f * layout[t.id].size / max(side, 1e-6))
    return float(np.mean(out))


def _candidates(
    known: Sequence[Tag], layout: Mapping[int, FieldTag], cfg: OnboardCamera, world: np.ndarray, image: np.ndarray
) -> list[tuple[float, float, float]]:
    """Robot poses on the floor to refine from: SQPnP over every corner for several tags (each tag's IPPE poses when
    it places the camera off its mount); for one tag IPPE's poses and each one's mirror image about the tag's normal
    (far off, perspective cannot tell a tag seen from an angle left of its normal from one seen as far right)."""
    lo = lens(cfg)
    poses: list[tuple[np.ndarray, np.ndarray]] = []  # (camera-to-map rotation, camera centre) [m]
    if len(known) > 1:
        ok, rv, tv = cv2.solvePnP(world, image, lo.K, lo.dist, flags=cv2.SOLVEPNP_SQPNP)
        if ok:
            r, _ = cv2.Rodrigues(rv)  # map -> camera
            poses.append((r.T, -r.T @ tv.ravel()))
    out = _on_floor(cfg, poses, MAX_TILT_OFF)
    if out:
        return out
    for t in known:  # far off, IPPE places the camera's height poorly: every pose is refined, the floor decides
        out += _on_floor(cfg, _ippe(layout[t.id], t.corners.astype(np.float64), lo.K, lo.dist), math.inf)
    if len(known) == 1:
        out += [_mirror(cfg, layout[known[0].id], p) for p in out]
    return out


def _ippe(tag: FieldTag, corners: np.ndarray, k: np.ndarray, dist: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """IPPE's two camera poses (camera-to-map rotation, centre [m]) from one tag's corners."""
    h = tag.size / 2.0
    square = np.array([[-h, h, 0.0], [h, h, 0.0], [h, -h, 0.0], [-h, -h, 0.0]])
    r_tag = rotation(tag.yaw, tag.pitch, tag.roll)
    to_map = np.column_stack([r_tag[:, 1], r_tag[:, 2], r_tag[:, 0]])  # IPPE's square frame: right, up, out
    n, rvecs, tvecs, _ = cv2.solvePnPGeneric(square, corners, k, dist, flags=cv2.SOLVEPNP_IPPE_SQUARE)
    out = []
    for rv, tv in zip(rvecs[:n], tvecs[:n]):
        r, _ = cv2.Rodrigues(rv)  # square frame -> camera
        r_cam = to_map @ r.T  # camera -> map
        out.append((r_cam, np.array([tag.x, tag.y, tag.z]) - r_cam @ tv.ravel()))
    return out


def _on_floor(cfg: OnboardCamera, poses: Sequence[tuple[np.ndarray, np.ndarray]], tol: float) -> list[tuple[float, float, float]]:
    """The robot poses of camera poses that keep the camera within tol [m] of its mounted height."""
    r_rc, t_rc = robot_to_camera(cfg)
    out = []
    for r_cam, centre in poses:
        if abs(centre[2] - cfg.z) > tol:
            continue
        body = r_cam @ r_rc.T  # robot -> map, tilted by the solution's errors
        theta = math.atan2(body[1, 0], body[0, 0])
        off = rotation(theta) @ t_rc
        out.append((float(centre[0] - off[0]), float(centre[1] - off[1]), theta))
    return out


def _mirror(cfg: OnboardCamera, tag: FieldTag, pose: tuple[float, float, float]) -> tuple[float, float, float]:
    """The robot pose whose camera sees the tag from the mirror image of `pose`'s bearing about the tag's normal."""
    cam = mount(cfg, *pose).C[:2]
    centre = np.array([tag.x, tag.y])
    normal = rotation(tag.yaw, tag.pitch, tag.roll)[:2, 0]
    if np.linalg.norm(normal) < 1e-6:  # a tag flat on the floor: no such mirror
        return pose
    normal = normal / np.linalg.norm(normal)
    rel = cam - centre
    mirrored = centre + 2.0 * (rel @ normal) * normal - rel
    look = pose[2] + cfg.yaw  # the optical axis's heading
    bearing = math.atan2(-rel[1], -rel[0])  # camera to tag
    bearing_m = math.atan2(centre[1] - mirrored[1], centre[0] - mirrored[0])
    theta = wrap_angle(bearing_m - (look - bearing) - cfg.yaw)
    off = rotation(theta) @ robot_to_camera(cfg)[1]
    return float(mirrored[0] - off[0]), float(mirrored[1] - off[1]), theta


def nuisance(cfg: OnboardCamera, tags: int) -> np.ndarray:
    """1 sigma of what a realistic camera's fix solves beside the pose, each held near 0 by that prior: the camera's
    pitch off its mounted one [rad] (the mount's error and shake), the printed tags' scale off 1, and each tag's centre
    off its layout (x, y, z [m]). None for an ideal camera."""
    if cfg.model == "ideal":
        return np.zeros(0)
    tilt = math.sqrt(cfg.mount_tilt**2 + cfg.vibration**2)
    return np.maximum([tilt, cfg.print_scale_error, *[cfg.tag_position_error] * (3 * tags)], PRIOR_LEAST)


@dataclass(frozen=True)
class _Problem:
    """One frame's least squares: the corners, where the lens shows them, the nuisances' priors, and what every
    projection of them shares (worked out once a frame, not once a projection)."""

    cfg: OnboardCamera
    world: np.ndarray  # N x 3 [m] the tags' corners on the field, 4 a tag
    target: np.ndarray  # (2N,) [px] where the lens shows them, u and v a corner
    weights: np.ndarray  # [px per rad, px per m] corner_sigma / each nuisance's prior (nuisance()); none for an ideal camera
    prior_rows: np.ndarray  # the priors' rows under the Jacobian, [0 | diag(weights)]
    centres: np.ndarray  # N x 3 [m] each corner's tag's centre (the print scale grows a tag about it)
    arms: np.ndarray  # N x 3 [m] each corner off its tag's centre
    yaw: np.ndarray  # 3 x 3 the mount's yaw, left of its pitch in robot -> camera axes ...
    roll: np.ndarray  # 3 x 3 ... and its roll and the camera's axes, right of it
    t_rc: np.ndarray  # [m] the optical centre in the robot frame


def _problem(cfg: OnboardCamera, world: np.ndarray, image: np.ndarray, priors: np.ndarray) -> _Problem:
    """The least squares of the corners `world` the lens shows at `image` (N x 2 [px]), nuisances of sizes `priors`."""
    centres = np.repeat(world.reshape(-1, 4, 3).mean(axis=1), 4, axis=0)
    weights = cfg.corner_sigma / priors
    roll = rotation(0.0, 0.0, cfg.roll) @ CAMERA_AXES  # CAMERA_AXES only permutes and negates: folded in first, the same bits
    prior_rows = np.hstack([np.zeros((len(weights), 3)), np.diag(weights)])
    t_rc = robot_to_camera(cfg)[1]
    return _Problem(cfg, world, image.reshape(-1), weights, prior_rows, centres, world - centres, rotation(cfg.yaw), roll, t_rc)


def _project(p: _Problem, poses: np.ndarray) -> np.ndarray:
    """(P x 2N) [px] where the camera of a robot at each of `poses` (P x (x, y, theta[, the nuisances])) shows the
    corners: OpenCV's projection (its five-coefficient distortion), for every pose at once."""
    cfg, n = p.cfg, len(poses)
    pts = np.broadcast_to(p.world, (n, *p.world.shape))
    pitch = np.full(n, cfg.pitch)
    if poses.shape[1] > 3:  # the camera's pitch, the tags' print scale and places
        pitch = pitch + poses[:, 3]
        shift = np.repeat(poses[:, 5:].reshape(n, -1, 3), 4, axis=1)
        pts = p.centres + p.arms * (1.0 + poses[:, 4, None, None]) + shift
    r_rc = p.yaw @ _about_y(pitch) @ p.roll  # robot -> camera axes
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    zero, one = np.zeros(n), np.ones(n)
    body = np.stack([c, -s, zero, s, c, zero, zero, zero, one], axis=1).reshape(n, 3, 3)  # robot -> map
    axes = body @ r_rc  # camera axes in the map (columns)
    centre = np.stack([poses[:, 0], poses[:, 1], zero], axis=1) + body @ p.t_rc
    cam = np.einsum("pji,pnj->pni", axes, pts - centre[:, None, :])  # camera frame
    x, y = cam[..., 0] / cam[..., 2], cam[..., 1] / cam[..., 2]
    r2 = x * x + y * y
    radial = 1.0 + r2 * (cfg.k1 + r2 * (cfg.k2 + r2 * cfg.k3))
    xd = x * radial + 2.0 * cfg.p1 * x * y + cfg.p2 * (r2 + 2.0 * x * x)
    yd = y * radial + cfg.p1 * (r2 + 2.0 * y * y) + 2.0 * cfg.p2 * x * y
    cx, cy = cfg.principal
    return np.stack([cfg.fx * xd + cx, cfg.fy * yd + cy], axis=-1).reshape(n, -1)


def _about_y(angle: np.ndarray) -> np.ndarray:
    """(P x 3 x 3) rotations by each angle [rad] about y."""
    c, s = np.cos(angle), np.sin(angle)
    zero, one = np.zeros(len(angle)), np.ones(len(angle))
    return np.stack([c, zero, s, zero, one, zero, -s, zero, c], axis=1).reshape(-1, 3, 3)


@functools.lru_cache(maxsize=16)
def _differences(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """How a pose of `n` values (x, y, theta[, pitch, scale, each tag's x, y, z]) is differenced: the moves (K x n),
    their sizes (K,), and for each nuisance of a tag's place, the move it takes (its axis) and the rows it keeps (its
    tag's 4 corners, u and v): one move along an axis for every tag at once."""
    first = min(n, 5)
    tags = max(n - 5, 0) // 3
    moves = np.zeros((first + (3 if tags else 0), n))
    for i in range(first):
        moves[i, i] = 1e-6 if i in (2, 3) else 1e-5  # [rad] angles, [m] or [-] the rest
    for axis in range(3) if tags else ():
        moves[first + axis, 5 + axis :: 3] = 1e-5
    axis_of = first + np.tile(np.arange(3), tags)  # column 5 + 3 t + a: tag t's axis a
    keeps = np.repeat(np.arange(tags), 8)[None, :] == np.repeat(np.arange(tags), 3)[:, None]  # (3 tags x 8 tags)
    return moves, 2.0 * moves.max(axis=1), axis_of, keeps


def _moved(poses: np.ndarray) -> np.ndarray:
    """(2 S K x n) what _jacobians projects about the poses (S x n): each moved by each of _differences' moves, then
    back by each."""
    moves = _differences(poses.shape[1])[0]
    return np.concatenate([poses[:, None] + moves, poses[:, None] - moves], axis=1).reshape(-1, poses.shape[1])


def _jacobians(p: _Problem, projected: np.ndarray, n: int) -> np.ndarray:
    """(S x M x n) the Jacobians [px per m, px per rad] of the residuals at S poses of `n` values: the projection's by
    central differences, from the projections of their _moved poses, and under it the nuisances' priors' (constant).
    A tag's place moves only its own corners: one difference moving every tag along an axis gives each tag's column
    (its rows, zeros elsewhere)."""
    _, sizes, axis_of, keeps = _differences(n)
    got = projected.reshape(-1, 2, len(sizes), projected.shape[1])
    diffs = (got[:, 0] - got[:, 1]) / sizes[:, None]  # S x K x 2N
    if len(axis_of):
        diffs = np.concatenate([diffs[:, :5], diffs[:, axis_of] * keeps], axis=1)
    j: np.ndarray = diffs.transpose(0, 2, 1)
    if not len(p.weights):
        return j
    return np.concatenate([j, np.broadcast_to(p.prior_rows, (len(j), *p.prior_rows.shape))], axis=1)


def _residuals(p: _Problem, poses: np.ndarray, projected: np.ndarray) -> np.ndarray:
    """(S x M) [px] the corners' reprojection errors at each of `poses`, from their projections, and the nuisances'
    priors (0 +- priors) as more residuals in corner sigmas."""
    return np.concatenate([projected - p.target, p.weights * poses[:, 3:]], axis=1)


def _refine(p: _Problem, seeds: Sequence[tuple[float, float, float]]) -> np.ndarray:
    """(S x n) the floor poses nearest each seed that best reproject the corners (Gauss-Newton), the nuisances
    solved beside them. The seeds are refined together, their moved poses projected in one call a step; a seed whose
    step is done stops there."""
    poses = np.hstack([np.array(seeds, dtype=np.float64), np.zeros((len(seeds), len(p.weights)))])
    moving = np.arange(len(seeds))
    for _ in range(ITERATIONS):
        at = poses[moving]
        got = _project(p, np.vstack([at, _moved(at)]))
        r, j = _residuals(p, at, got[: len(at)]), _jacobians(p, got[len(at) :], at.shape[1])
        step = np.array([np.linalg.lstsq(ji, -ri, rcond=None)[0] for ji, ri in zip(j, r)])
        poses[moving] = at + step
        moving = moving[np.max(np.abs(step), axis=1) >= STEP_DONE]
        if not len(moving):
            break
    return poses


def _outcomes(p: _Problem, poses: np.ndarray) -> list[tuple[tuple[float, float, float], float, np.ndarray]]:
    """Each refined pose (S x n) on the floor, its rms reprojection error [px], and the Jacobian (M x n) its
    covariance is drawn from: at the pose with its nuisances back at 0. One projection for all of them."""
    floor = [(float(x), float(y), wrap_angle(float(t))) for x, y, t in poses[:, :3]]
    at = np.hstack([np.array(floor), np.zeros((len(poses), len(p.weights)))])
    got = _project(p, np.vstack([poses, _moved(at)]))
    r = _residuals(p, poses, got[: len(poses)])
    rms = [float(np.sqrt(np.sum(ri**2) / len(p.target))) for ri in r]
    return list(zip(floor, rms, _jacobians(p, got[len(poses) :], poses.shape[1])))


def _covariance(cfg: OnboardCamera, j: np.ndarray) -> tuple[float, ...]:
    """corner_sigma^2 (J^T J)^-1 (the nuisances' priors in J, then left out), 3x3 row-major, with the least variances added."""
    try:
        cov = np.linalg.inv(j.T @ j)[:3, :3] * cfg.corner_sigma**2
    except np.linalg.LinAlgError:
        cov = np.diag([1.0, 1.0, 1.0])
    cov = cov + np.diag(VAR_FLOOR)
    return tuple(float(v) for v in cov.ravel())


def _same(a: Sequence[float], b: Sequence[float], cov: tuple[float, ...]) -> bool:
    """Whether two refined poses are one: within SAME of each other, or within the fix's own 3 sigma (a flat valley)."""
    d = np.array([a[0] - b[0], a[1] - b[1], wrap_angle(a[2] - b[2])])
    close = math.hypot(d[0], d[1]) < SAME[0] and abs(d[2]) < SAME[1]
    return close or float(d @ np.linalg.solve(np.array(cov).reshape(3, 3), d)) < SAME_D2


def _gap(a: Sequence[float], b: Sequence[float]) -> float:
    """How far pose a is from b, in units of PRIOR_GATE (<= 1: within the gate)."""
    return max(math.hypot(a[0] - b[0], a[1] - b[1]) / PRIOR_GATE[0], abs(wrap_angle(a[2] - b[2])) / PRIOR_GATE[1])


def _by_estimate(
    a: tuple[float, float, float], b: tuple[float, float, float], estimate: tuple[float, float, float] | None
) -> tuple[float, float, float] | None:
    """The candidate the estimate clearly points to (within its gate, the other PRIOR_MARGIN times farther), else None."""
    if estimate is None:
        return None
    ga, gb = _gap(a, estimate), _gap(b, estimate)
    near, far, pick = (ga, gb, a) if ga <= gb else (gb, ga, b)
    return pick if near <= 1.0 and far >= PRIOR_MARGIN * max(near, 1e-9) else None
