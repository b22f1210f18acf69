"""A figure into a PNG: rendered once, cropped to its content.

- ``new_figure``: a Figure on its own Agg canvas, outside pyplot: no global registry to close it
  from, and no interactive backend is ever looked for.
- ``save_figure``: the figure rendered once on a canvas grown by ``MARGIN_INCHES`` on every side (a
  tick label or an axis label reaching past the figure's edge is drawn there, not cut off), then
  cropped to the pixels that differ from the figure's background plus ``PAD_INCHES``, as
  savefig(bbox_inches="tight") pads, and written as an RGB PNG.

Why not savefig(bbox_inches="tight"): it lays every text and tick out once to measure the figure,
then again to render it (0.1-0.5 s a figure here, a third of a report's drawing); the bounding box
of the rendered pixels needs no second pass. The figure is white and opaque, so the PNG needs no
alpha channel (a quarter less to compress: faster and smaller at zlib level ``PNG_LEVEL``). Content
that reaches the margin's outer edge falls back to savefig's tight box; content entirely beyond
the margin is not drawn at all and cannot be seen from the pixels: it is cut (the report's figures
reach at most 0.1 inch past their edges).
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np

from bayes_dnlr.diskio import storage_error
from bayes_dnlr.report.figure_cache import png_metadata

DPI = 110
PAD_INCHES = 0.1        # matplotlib's pad around a bbox_inches="tight" figure
MARGIN_INCHES = 0.5     # room beyond the figure's edges for labels that reach past them
PNG_LEVEL = 3           # zlib level: 6 (Pillow's default) took 1.5x as long for files 3-6 % smaller


def new_figure(**kwargs):
    """A ``matplotlib.figure.Figure(**kwargs)`` on an Agg canvas."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(**kwargs)
    FigureCanvasAgg(fig)
    return fig


def _rendered(fig, margin: float) -> np.ndarray | None:
    """The figure's pixels (rows, columns, RGBA) on its canvas grown by ``margin`` inches (None:
    not the size asked for)."""
    from matplotlib.transforms import Bbox

    w, h = fig.get_size_inches()
    grown = Bbox.from_extents(-margin, -margin, w + margin, h + margin)
    fig.savefig(io.BytesIO(), format="rgba", dpi=DPI, bbox_inches=grown)
    if not hasattr(fig.canvas, "buffer_rgba"):         # not an Agg canvas: it kept no pixels
        return None
    pixels = np.asarray(fig.canvas.buffer_rgba())      # the rendering just printed
    size = np.array([grown.height, grown.width]) * DPI
    return pixels if np.all(np.abs(np.array(pixels.shape[:2]) - size) <= 1.0) else None


def _content(rgba: np.ndarray, background: tuple[int, ...]) -> tuple[slice, slice] | None:
    """Rows and columns of the pixels that are not ``background`` (None: there are none)."""
    pixels = rgba.view(np.uint32)[..., 0]
    key = np.array([background], np.uint8).view(np.uint32)[0]
    rows = np.flatnonzero((pixels != key).any(axis=1))
    if rows.size == 0:
        return None
    cols = np.flatnonzero((pixels[rows[0]:rows[-1] + 1] != key).any(axis=0))
    return slice(int(rows[0]), int(rows[-1]) + 1), slice(int(cols[0]), int(cols[-1]) + 1)


def _write_png(pixels: np.ndarray, path: Path) -> None:
    from PIL import Image
    from PIL.PngImagePlugin import PngInfo

    info = PngInfo()
    for key, value in png_metadata().items():
        info.add_text(key, value)
    Image.fromarray(np.ascontiguousarray(pixels)).save(path, format="png", compress_level=PNG_LEVEL,
                                                       pnginfo=info, dpi=(DPI, DPI))


def save_figure(fig, path: Path) -> Path:
    """Write the figure as PNG, cropped to its content plus PAD_INCHES like bbox_inches="tight",
    from a single rendering (see the module's docstring). A failed write (a full disk) leaves no
    temporary and raises StorageError naming the file."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")   # replaced in one step: never half a PNG
    try:
        tmp.unlink(missing_ok=True)
        _save(fig, tmp)
        os.replace(tmp, path)
    except BaseException as err:      # a full disk: no temporary left, and the file named
        try:
            tmp.unlink(missing_ok=True)
        except OSError:
            pass
        clean = storage_error(err, path, "the previous figures and page are kept")
        if clean is not None:
            raise clean from None
        raise
    if getattr(fig.canvas, "manager", None) is not None:     # a pyplot figure: drop it from pyplot
        import matplotlib.pyplot as plt

        plt.close(fig)
    return path


def _save(fig, tmp: Path) -> None:
    """The PNG of ``fig`` into ``tmp`` (see ``save_figure``)."""
    from matplotlib.colors import to_rgba

    background = tuple(int(round(c * 255)) for c in to_rgba(fig.get_facecolor()))
    rgba = _rendered(fig, MARGIN_INCHES) if background[3] == 255 else None
    box = _content(rgba, background) if rgba is not None else None
    pad = int(round(PAD_INCHES * DPI))
    if box is not None and min(box[0].start, box[1].start) >= pad and \
            box[0].stop + pad <= rgba.shape[0] and box[1].stop + pad <= rgba.shape[1]:
        rows, cols = slice(box[0].start - pad, box[0].stop + pad), slice(box[1].start - pad,
                                                                        box[1].stop + pad)
        _write_png(rgba[rows, cols, :3], tmp)
    else:                   # content past the margin, a transparent figure, or nothing drawn
        fig.savefig(tmp, dpi=DPI, bbox_inches="tight", pad_inches=PAD_INCHES, format="png",
                    metadata=png_metadata(), pil_kwargs={"compress_level": PNG_LEVEL})
