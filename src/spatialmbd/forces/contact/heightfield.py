"""Height fields (terrain, as MuJoCo's hfield) as contact shapes: a grid of heights over a
rectangle, a special triangle mesh (:mod:`.mesh_shape`) whose triangles are found by their grid
cell in O(1) instead of through a hierarchy (:mod:`.mesh_query`).

``{"type": "heightfield", "heights": [[z, ...], ...], "size": [Lx, Ly]}``: heights (m) in rows
along y and columns along x, (ny + 1) x (nx + 1) >= 2 x 2 values, over the rectangle
[-Lx/2, Lx/2] x [-Ly/2, Ly/2] of the shape frame (``center``, ``axes`` as for every shape),
the surface facing +z. Grid point (i, j) (column i, row j) is at x_i = -Lx/2 + i dx,
y_j = -Ly/2 + j dy (dx = Lx / nx, dy = Ly / ny). Each cell is split along its diagonal from
(i, j) to (i + 1, j + 1) into triangles 2 c and 2 c + 1, c = i + nx j:

    (x_i, y_j), (x_i+1, y_j), (x_i+1, y_j+1)     and     (x_i, y_j), (x_i+1, y_j+1), (x_i, y_j+1)

A shape touches the triangles of the cells its bounding box covers in x and y; the contacts
are those of the equivalent mesh (same triangles, same rule for edges and vertices).
"""
from __future__ import annotations

import numpy as np

from ...errors import ModelError
from . import mesh_shape as MS


def triangles(heights, size) -> tuple:
    """(vertices, faces, (nx, ny, x0, y0, dx, dy)) of the grid (module docstring)."""
    H = np.asarray(heights, dtype=float)
    ny, nx = H.shape[0] - 1, H.shape[1] - 1
    Lx, Ly = size
    dx, dy = Lx / nx, Ly / ny
    x0, y0 = -0.5 * Lx, -0.5 * Ly
    X, Y = np.meshgrid(x0 + dx * np.arange(nx + 1), y0 + dy * np.arange(ny + 1))
    V = np.column_stack([X.ravel(), Y.ravel(), H.ravel()])
    i, j = np.meshgrid(np.arange(nx), np.arange(ny))
    i, j = i.ravel(), j.ravel()              # cell c = i + nx j, in this order
    p00 = i + (nx + 1) * j
    p10, p01, p11 = p00 + 1, p00 + nx + 1, p00 + nx + 2
    F = np.empty((2 * nx * ny, 3), dtype=np.int64)
    F[0::2] = np.column_stack([p00, p10, p11])
    F[1::2] = np.column_stack([p00, p11, p01])
    return V, F, (nx, ny, x0, y0, dx, dy)


def parse_heightfield(shape, what) -> tuple:
    """(vertices, faces, neighbours, grid) of a height-field shape dict, checked: ModelError
    naming ``what``.heights[row][column] and the value for a non-finite height."""
    value = shape.get("heights")
    try:
        H = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{what}.heights: expected rows of numbers (m), got rows of "
                         "different lengths or non-numbers") from None
    if H.ndim != 2 or H.shape[0] < 2 or H.shape[1] < 2:
        raise ModelError(f"{what}.heights: expected (ny + 1) x (nx + 1) >= 2 x 2 heights (m) "
                         f"in rows along y, got shape {H.shape}")
    bad = np.argwhere(~np.isfinite(H))
    if bad.size:
        r, c = bad[0]
        raise ModelError(f"{what}.heights[{r}][{c}]: must be a finite height (m), got "
                         f"{H[r, c]!r}")
    size = shape.get("size")
    try:
        L = np.asarray(size, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        L = np.zeros(0)
    if L.size != 2 or not np.all(np.isfinite(L)) or not np.all(L > 0):
        raise ModelError(f"{what}.size: expected the extents [Lx, Ly] (m), two positive "
                         f"numbers, got {size!r}")
    V, F, grid = triangles(H, L)
    nb = MS.check_surface(V, F, what)
    return V, F, nb, grid
