"""Shared figure setup: the Agg backend, figures without pyplot's global state, encoding to bytes.

Every module of :mod:`actuator_design.viz` makes its figures here, so that drawing never touches
pyplot's global state (no window, no figure registry) and the backend is Agg unless the caller has
already chosen one through pyplot. matplotlib is imported only when a figure is made, so importing
any ``viz`` module is cheap and does not load matplotlib.

Figures leave ``viz`` as objects (for callers that compose panels) or as encoded bytes
(:func:`png_bytes`, :func:`gif_bytes`); writing bytes to files is :mod:`actuator_design.io.save`'s job.
"""
from __future__ import annotations

import contextlib
import contextvars
import importlib
import io
import os
import sys
import tempfile
from functools import partial
from typing import Callable, Dict, Iterator, List, Optional, Sequence, Tuple

import numpy as np

from actuator_design import forked

__all__ = ["new_figure", "new_axes", "new_axes_grid", "png_bytes", "png_side_by_side", "gif_bytes", "preload", "preload_steps", "no_offset_notation",
           "FigureBytes", "vector_format", "VECTOR_FORMATS"]

#: Vector formats a figure can be written in beside its PNG (``--format``).
VECTOR_FORMATS = ("svg", "pdf")

_VECTOR_FORMAT: contextvars.ContextVar = contextvars.ContextVar("vector_format", default=None)


class FigureBytes(bytes):
    """A figure's PNG bytes that also carry its encodings in vector formats.

    Attributes
    ----------
    vector : dict of str → bytes
        ``{"svg": ..., "pdf": ...}``: the same figure in each format asked for with
        :func:`vector_format` when :func:`png_bytes` ran (empty if none). Writers of an output set
        add ``name.svg`` beside ``name.png`` (:func:`actuator_design.cli.common.write_out`).
    """

    vector: Dict[str, bytes]

    def __new__(cls, png: bytes, vector: Optional[Dict[str, bytes]] = None):
        obj = super().__new__(cls, png)
        obj.vector = dict(vector or {})
        return obj


@contextlib.contextmanager
def vector_format(fmt: Optional[str]) -> Iterator[None]:
    """Within the block, :func:`png_bytes` also encodes each figure as ``fmt`` (``"svg"`` or
    ``"pdf"``; None: PNG only).

    Raises
    ------
    ValueError
        ``fmt`` is not one of :data:`VECTOR_FORMATS`.
    """
    if fmt is not None and fmt not in VECTOR_FORMATS:
        raise ValueError(f"figure format {fmt!r}: must be one of {', '.join(VECTOR_FORMATS)}")
    token = _VECTOR_FORMAT.set(fmt)
    try:
        yield
    finally:
        _VECTOR_FORMAT.reset(token)


def _use_agg() -> None:
    """Choose the Agg backend unless pyplot (and with it a user's backend) is already in use."""
    import matplotlib
    if "matplotlib.pyplot" not in sys.modules:
        matplotlib.use("Agg")


#: The modules a figure is drawn with, in import order, each loading a part (≤ 0.08 s) of the
#: ≈0.2 s matplotlib takes to load (:func:`preload_steps`).
_FIGURE_MODULES = ("matplotlib.text", "matplotlib.collections", "matplotlib.axes", "matplotlib.projections",
                   "matplotlib.figure", "matplotlib.backends.backend_agg")


def preload() -> None:
    """Import matplotlib's figure and Agg canvas now (≈0.2 s), e.g. while workers compute, so
    that drawing later does not wait for it."""
    for step in preload_steps():
        step()


def preload_steps() -> List[Callable[[], None]]:
    """:func:`preload` in steps of at most ≈0.08 s, for waits that may end at any moment
    (:func:`actuator_design.forked.while_waiting`: a step is run only while a forked task still
    computes, so a wait overruns by one step at most; the rest loads when a figure is drawn)."""
    return [_use_agg] + [partial(importlib.import_module, name) for name in _FIGURE_MODULES]


def new_figure(figsize: Tuple[float, float] = (6.4, 4.8)):
    """A new figure (constrained layout) that pyplot does not know about.

    Parameters
    ----------
    figsize : (float, float)
        Width and height in inches.

    Returns
    -------
    matplotlib.figure.Figure
    """
    _use_agg()
    from matplotlib.figure import Figure
    return Figure(figsize=figsize, layout="constrained")


def new_axes(figsize: Tuple[float, float] = (6.4, 5.2)):
    """The single axes of a :func:`new_figure` of size ``figsize`` (inches)."""
    return new_figure(figsize).add_subplot()


def new_axes_grid(nrows: int = 1, ncols: int = 1, panel_size: Tuple[float, float] = (6.4, 4.6)):
    """A figure of ``nrows`` × ``ncols`` panels of ``panel_size`` inches each.

    Returns
    -------
    fig : matplotlib.figure.Figure
    axes : ndarray of Axes, shape (nrows, ncols)
    """
    fig = new_figure((panel_size[0] * ncols, panel_size[1] * nrows))
    return fig, fig.subplots(nrows, ncols, squeeze=False)


def png_bytes(figure, dpi: int = 150) -> FigureBytes:
    """The PNG encoding of a figure (or of the figure an ``Axes`` belongs to).

    Parameters
    ----------
    figure : matplotlib.figure.Figure or matplotlib.axes.Axes
    dpi : int
        Resolution in dots per inch.

    Returns
    -------
    FigureBytes
        A PNG file's content; inside :func:`vector_format` it also carries the figure in that
        format (without a creation date, so the same figure gives the same bytes).
    """
    fig = getattr(figure, "figure", None) if not hasattr(figure, "savefig") else figure
    no_offset_notation(fig)
    return FigureBytes(_encode_png(_rgba(fig, dpi), dpi), _vector(fig))


def png_side_by_side(parts: Sequence[Callable[[], object]], dpi: int = 150,
                     whole: Optional[Callable[[], object]] = None) -> FigureBytes:
    """One PNG of figures drawn side by side, top-aligned (white below a shorter one).

    Each part after the first is made and drawn in a forked copy of this process
    (:mod:`actuator_design.forked`) while this one draws the first, so a figure of many panels
    drawn as parts takes the time of its largest part (the design figure: 0.33 s → 0.2 s).

    Parameters
    ----------
    parts : sequence of callables
        Each returns a matplotlib Figure (picklable, e.g. a ``functools.partial``).
    dpi : int
        Resolution in dots per inch.
    whole : callable, optional
        The same figure in one piece, drawn instead when :func:`vector_format` asks for a vector
        encoding too (a vector file is one figure, not pixels put together).

    Returns
    -------
    FigureBytes
    """
    if _VECTOR_FORMAT.get() is not None:
        if whole is None:
            raise ValueError("png_side_by_side: a vector format was asked for (vector_format): give `whole`")
        return png_bytes(whole(), dpi)
    beside = [forked.start(partial(_part_rgba, part, dpi)) for part in parts[1:]]
    try:
        images = [_part_rgba(parts[0], dpi)] + [job.result() for job in beside]
    finally:
        for job in beside:
            job.cancel()
    height = max(im.shape[0] for im in images)
    white = np.array([255, 255, 255, 255], np.uint8)
    images = [np.concatenate([im, np.broadcast_to(white, (height - im.shape[0], im.shape[1], 4))])
              for im in images]
    return FigureBytes(_encode_png(np.concatenate(images, axis=1), dpi))


def _part_rgba(make: Callable[[], object], dpi: int) -> np.ndarray:
    fig = make()
    no_offset_notation(fig)
    return _rgba(fig, dpi)


def _rgba(fig, dpi: int) -> np.ndarray:
    """The figure's pixels at ``dpi``, shape (height, width, 4), uint8 RGBA: one Agg draw, the
    layout engine run within it (``savefig`` draws twice with a layout engine, the first time
    only to lay out: the same pixels, 0.08 s more on the design figure)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    old_canvas, old_dpi = fig.canvas, fig.dpi
    canvas = FigureCanvasAgg(fig)
    try:
        fig.set_dpi(dpi)
        canvas.draw()
        return np.array(canvas.buffer_rgba())
    finally:
        fig.set_dpi(old_dpi)
        fig.set_canvas(old_canvas)


def _encode_png(rgba: np.ndarray, dpi: int) -> bytes:
    """PNG bytes of an RGBA image, as ``savefig`` writes them (matplotlib's metadata, ``dpi``)."""
    import matplotlib.image

    buf = io.BytesIO()
    matplotlib.image.imsave(buf, rgba, format="png", dpi=dpi, origin="upper")  # (not rcParams' image.origin)
    return buf.getvalue()


def _vector(fig) -> Dict[str, bytes]:
    """The figure in the vector format :func:`vector_format` asks for (``{}``: none asked)."""
    fmt = _VECTOR_FORMAT.get()
    if fmt is None:
        return {}
    import matplotlib
    out = io.BytesIO()
    metadata = {"Date": None} if fmt == "svg" else {"CreationDate": None}
    with matplotlib.rc_context({"svg.hashsalt": "actuator-design", "svg.fonttype": "path"}):
        fig.savefig(out, format=fmt, metadata=metadata)
    return {fmt: out.getvalue()}


def no_offset_notation(fig) -> None:
    """Tick labels as the values themselves on every linear axis of ``fig``: matplotlib's offset
    notation wrote a stiffness axis as "1e−6 + 5.11194", which reads as a different number. Only
    the figure's own axes are changed (no global rcParams: a user's plots stay as they are)."""
    from matplotlib.ticker import ScalarFormatter
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            fmt = axis.get_major_formatter()
            if isinstance(fmt, ScalarFormatter):
                fmt.set_useOffset(False)


def gif_bytes(animation, fps: int = 12) -> bytes:
    """The GIF encoding of a ``matplotlib.animation.Animation`` (Pillow writer).

    Pillow's writer needs a file name, so the frames pass through a private temporary directory that
    is removed before returning; nothing is written anywhere the caller can see.
    """
    from matplotlib.animation import PillowWriter
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "animation.gif")
        animation.save(path, writer=PillowWriter(fps=fps))
        with open(path, "rb") as fh:
            return fh.read()
