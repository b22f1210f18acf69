"""A figure rendered once gives the PNG savefig(bbox_inches="tight") gives: the same box around the
same content, labels past the figure's edge included."""

from __future__ import annotations

import io

import numpy as np
from PIL import Image

from bayes_dnlr.report.canvas import DPI, PAD_INCHES, new_figure, save_figure


def _figure(label_y: float = -0.25):
    fig = new_figure(figsize=(4.0, 2.0))
    ax = fig.subplots()
    fig.subplots_adjust(bottom=0.05)                  # the x label falls below the figure's edge
    ax.plot([0.0, 1.0], [0.0, 1.0])
    ax.set_xlabel("strain", fontsize=14)
    ax.text(0.5, label_y, "below", transform=ax.transAxes, ha="center")
    return fig


def _tight(fig) -> np.ndarray:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI, bbox_inches="tight", pad_inches=PAD_INCHES)
    return np.asarray(Image.open(buf).convert("RGB"))


def test_the_crop_is_savefigs_tight_box(tmp_path):
    tight = _tight(_figure())
    path = save_figure(_figure(), tmp_path / "f.png")
    with Image.open(path) as im:
        assert im.mode == "RGB"                       # opaque figure: no alpha channel
        ours = np.asarray(im)
    assert abs(ours.shape[0] - tight.shape[0]) <= 4 and abs(ours.shape[1] - tight.shape[1]) <= 4
    assert ours.shape[0] > 2.0 * DPI                  # taller than the figure: the label is in it
    dark = np.flatnonzero((ours < 128).any(axis=(1, 2)))
    assert ours.shape[0] - 1 - dark[-1] >= PAD_INCHES * DPI - 2      # padded below the last text


def test_content_at_the_margins_edge_falls_back_to_the_tight_box(tmp_path):
    tight = _tight(_figure(label_y=-0.33))            # text down to the grown canvas's edge
    path = save_figure(_figure(label_y=-0.33), tmp_path / "f.png")
    with Image.open(path) as im:
        assert im.size == (tight.shape[1], tight.shape[0])
