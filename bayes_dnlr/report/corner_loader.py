"""corner's plotting function for arrays, imported without the modules the report does not use.

``import corner`` imports corner.arviz_corner, which imports all of ArviZ (1-2 s), for DataTree
input the report never passes; and corner.core imports scipy.ndimage (0.35-0.45 s of CPU, with
scipy.special and scipy.linalg), only for ``gaussian_filter``, the smoothing of its 2-D
histograms. Both modules are reported missing while corner loads (corner's own fallbacks when
ArviZ or scipy is absent) and restored after: corner.corner still accepts a DataTree in this
process (ArviZ then loads on that first call), and the smoothing is ``gaussian_filter`` below, the
same filter as scipy's for what corner asks of it (tested against scipy).
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence

import numpy as np


def gaussian_filter(values: np.ndarray, sigma: float | Sequence[float], truncate: float = 4.0
                    ) -> np.ndarray:
    """scipy.ndimage.gaussian_filter(values, sigma) for order 0 and mode "reflect" (its defaults,
    what corner uses): the separable Gaussian kernel of radius round(truncate·σ), the edges
    reflected (d c b a | a b c d | d c b a)."""
    out = np.asarray(values, dtype=float)
    sigmas = np.broadcast_to(np.asarray(sigma, dtype=float), (out.ndim,))
    for axis, s in enumerate(sigmas):
        radius = int(truncate * s + 0.5)
        if s <= 0 or radius == 0:
            continue
        offsets = np.arange(-radius, radius + 1)
        weights = np.exp(-0.5 * (offsets / s) ** 2)
        weights /= weights.sum()
        pad = [(radius, radius) if a == axis else (0, 0) for a in range(out.ndim)]
        padded = np.pad(out, pad, mode="symmetric")
        n = out.shape[axis]
        out = sum(w * np.take(padded, np.arange(k, k + n), axis=axis) for k, w in enumerate(weights))
    return out


def _arviz_corner(*args, **kwargs):
    from corner.arviz_corner import arviz_corner

    return arviz_corner(*args, **kwargs)


def corner_impl() -> Callable:
    """``corner.core.corner_impl``, corner loaded without ArviZ and without scipy.ndimage when
    neither is loaded yet (see the module's docstring)."""
    if "corner" not in sys.modules:
        hidden = [m for m in ("corner.arviz_corner", "scipy.ndimage")
                  if m not in sys.modules and not (m == "corner.arviz_corner" and "arviz" in sys.modules)]
        for name in hidden:
            sys.modules[name] = None        # `from <name> import ...` raises ImportError
        try:
            import corner.core
            import corner.corner as front
        finally:
            for name in hidden:
                if sys.modules.get(name, 0) is None:
                    del sys.modules[name]
        if getattr(front, "arviz_corner", 0) is None:
            front.arviz_corner = _arviz_corner
        if corner.core.gaussian_filter is None:
            corner.core.gaussian_filter = gaussian_filter
    from corner.core import corner_impl as impl

    return impl
