"""A tag36h11 read from its outline: its code (`read`) and its edges (`refine`), with OpenCV and numpy.

OpenCV's aruco module finds tag outlines with its port of the AprilTag library's quad
detector, but its decoding of them samples each cell at one pixel (no interpolation),
half a pixel off (the outlines come in the AprilTag library's pixel convention), which
loses most tags under ~20 px; and its port does not refine the edges of outlines found on
a decimated frame, which leaves them up to a pixel off. These two steps do what the
AprilTag library does instead. Outlines here are in OpenCV's pixel convention (pixel
centres at whole numbers), clockwise as seen.
"""

from __future__ import annotations

from typing import Any

import numpy as np

CELLS = 8  # cells across the black square of a tag36h11: a 6 x 6 code inside a one-cell black border
SAMPLES = (0.375, 0.625)  # where in a cell (its fraction) it is sampled, 2 x 2: its middle, clear of blur from the next
SHARPEN = 0.25  # weight of the cells' Laplacian added to them (the AprilTag library's decode_sharpening)
MIN_CONTRAST = 5.0  # [grey levels] least white margin less black border (the AprilTag library's min_white_black_diff)
MAX_BORDER_ERRORS = 4  # cells of the black border (28) read as white, at most
CORRECTION_RATE = 0.4  # of the tag36h11 dictionary's 5 correctable bits: 2 (the AprilTag library's default)
EDGE_STEP = 0.25  # [px] between the places along an edge's normal the edge is looked for
MIN_EDGE_POINTS = 16  # points along an edge the edge is looked for at, at least (one per 8 px beyond)

_SQUARE = np.array([[0, 0], [CELLS, 0], [CELLS, CELLS], [0, CELLS]], dtype=np.float32)  # the outline in cell units
_N = CELLS + 2  # cells across with the white margin
_K = len(SAMPLES)
_u = (np.arange(-1, CELLS + 1)[:, None] + np.array(SAMPLES)[None, :]).ravel()
_GRID = np.stack([*np.meshgrid(_u, _u), np.ones((_N * _K, _N * _K))], axis=-1).reshape(-1, 3)  # sample points, homogeneous
_RING = np.ones((_N, _N), bool)
_RING[1:-1, 1:-1] = False  # the white margin around the black square
_BORDER = np.zeros((_N, _N), bool)
_BORDER[1:-1, 1:-1] = True
_BORDER[2:-2, 2:-2] = False  # the black border


def read(cv2: Any, img: np.ndarray, quads: np.ndarray, dictionary: Any) -> list[tuple[int, int, int, float]]:
    """The tags the outlines `quads` (N x 4 x 2 [px]) hold: (index in quads, tag id, rotation, decision margin [grey levels]).

    Each cell is sampled between pixels at 2 x 2 points of its middle, the cells sharpened; the threshold is midway
    between the black border and the white margin; the code is looked up in `dictionary`. Rotation r: the printed
    top-left corner is the outline's corner r."""
    if len(quads) == 0:
        return []
    H = np.stack([cv2.getPerspectiveTransform(_SQUARE, q.astype(np.float32)) for q in quads])
    p = np.einsum("nij,sj->nsi", H, _GRID)
    xy = (p[..., :2] / p[..., 2:]).astype(np.float32).reshape(-1, _N * _K, 2)
    values = cv2.remap(img, xy[..., 0], xy[..., 1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    cells = values.astype(np.float64).reshape(len(quads), _N, _K, _N, _K).mean(axis=(2, 4))
    pad = np.pad(cells, ((0, 0), (1, 1), (1, 1)), mode="edge")
    cells = cells + SHARPEN * (4.0 * cells - pad[:, :-2, 1:-1] - pad[:, 2:, 1:-1] - pad[:, 1:-1, :-2] - pad[:, 1:-1, 2:])
    white, black = cells[:, _RING].mean(axis=1), cells[:, _BORDER].mean(axis=1)
    threshold = (white + black) / 2.0
    border_errors = np.count_nonzero(cells[:, _BORDER] > threshold[:, None], axis=1)
    out = []
    for i in np.flatnonzero((white - black >= MIN_CONTRAST) & (border_errors <= MAX_BORDER_ERRORS)):
        code = cells[i, 2:-2, 2:-2]
        found, tag_id, rotation = dictionary.identify((code > threshold[i]).astype(np.uint8), CORRECTION_RATE)
        if found:
            out.append((int(i), int(tag_id), int(rotation), float(np.min(np.abs(code - threshold[i])))))
    return out


def refine(cv2: Any, img: np.ndarray, quad: np.ndarray, reach: float) -> np.ndarray:
    """The outline (4 x 2 [px]) with each edge moved onto the image's, looked for within `reach` [px] of it.

    The AprilTag library's refine_edges: at points along each edge, the steepest rise from the black square out to
    the white margin within `reach` of it (its weighted mean place); a line fitted through them; the corners where
    adjacent lines meet. An edge with too few such points leaves the outline as it was."""
    a, b = quad, np.roll(quad, -1, axis=0)
    along = b - a  # 4 x 2: edge i runs from corner i to corner i + 1
    length = np.linalg.norm(along, axis=1)
    normal = np.stack([along[:, 1], -along[:, 0]], axis=1) / np.maximum(length, 1e-9)[:, None]
    normal *= np.sign(np.sum(normal * ((a + b) / 2.0 - quad.mean(axis=0)), axis=1))[:, None]  # outward
    m = max(MIN_EDGE_POINTS, int(length.max() / 8.0))
    points = a[:, None, :] + ((np.arange(m) + 1.0) / (m + 1.0))[None, :, None] * along[:, None, :]  # 4 x m x 2
    offsets = np.arange(-reach, reach + 1e-9, EDGE_STEP)
    probe = points[:, :, None, :] + offsets[None, None, :, None] * normal[:, None, None, :]  # 4 x m x k x 2
    both = np.stack([probe + normal[:, None, None, :], probe - normal[:, None, None, :]]).astype(np.float32).reshape(-1, len(offsets), 2)
    values = cv2.remap(img, both[..., 0], both[..., 1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE).astype(np.float64)
    outer, inner = values.reshape(2, 4, m, len(offsets))
    weight = np.clip(outer - inner, 0.0, None) ** 2  # a rise outwards only: the black square's edge
    total = weight.sum(axis=2)
    lines = []
    for i in range(4):
        ok = total[i] > 0.0
        if np.count_nonzero(ok) < 2:
            return quad
        moved = points[i, ok] + ((weight[i, ok] @ offsets) / total[i, ok])[:, None] * normal[i]
        centre = moved.mean(axis=0)
        lines.append((centre, np.linalg.svd(moved - centre)[2][0]))  # a point on the line and its direction
    corners = []
    for i in range(4):  # edge i - 1 (into corner i) and edge i (out of it) meet at corner i
        (p, d), (q, e) = lines[i - 1], lines[i]
        m2 = np.column_stack([d, -e])
        if abs(np.linalg.det(m2)) < 1e-9:
            return quad
        corners.append(p + np.linalg.solve(m2, q - p)[0] * d)
    return np.array(corners)
