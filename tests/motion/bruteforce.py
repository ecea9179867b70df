"""A plain exhaustive SAD block matcher: the reference the fast one must equal."""

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view


def brute_force_vectors(prev, cur, block, search, min_std):
    p = prev.astype(np.float32)
    c = cur.astype(np.float32)
    h, w = c.shape
    out = []
    for by in range(0, h - block + 1, block):
        for bx in range(0, w - block + 1, block):
            blk = c[by:by + block, bx:bx + block]
            if blk.std() < min_std:
                continue
            y0, y1 = max(0, by - search), min(h - block, by + search)
            x0, x1 = max(0, bx - search), min(w - block, bx + search)
            region = p[y0:y1 + block, x0:x1 + block]
            win = sliding_window_view(region, (block, block))
            sad = np.abs(win - blk).sum(axis=(2, 3), dtype=np.float64)
            iy, ix = np.unravel_index(int(np.argmin(sad)), sad.shape)
            out.append((bx - (x0 + ix), by - (y0 + iy)))
    return np.asarray(out, dtype=np.float64).reshape(-1, 2)
