"""Shared figure setup: the Agg backend, figures without pyplot's global state, encoding to bytes.

Every module of :mod:`actuator_design.viz` makes its figures here, so that drawing never touches
pyplot's global state (no window, no figure registry) and the backend is Agg unless the caller has
already chosen one through pyplot. matplotlib is imported only when a figure is made, so importing
any ``viz`` module is cheap and does not load matplotlib.

Figures leave ``viz`` as objects (for callers that compose panels) or as encoded bytes
(:func:`png_bytes`, :func:`gif_bytes`); writing bytes to files is :mod:`actuator_design.io`'s job.
"""
from __future__ import annotations

import contextlib
import contextvars
import io
import os
import sys
import tempfile
from typing import Dict, Iterator, Optional, Tuple

__all__ = ["new_figure", "new_axes", "new_axes_grid", "png_bytes", "gif_bytes", "preload", "no_offset_notation",
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
        add ``name.svg`` beside ``name.png`` (:func:`actuator_design.cli.output.write_out`).
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


def preload() -> None:
    """Import matplotlib's figure and Agg canvas now (≈0.5 s), e.g. in a thread while workers
    compute, so that drawing later does not wait for it."""
    _use_agg()
    import matplotlib.backends.backend_agg  # noqa: F401
    import matplotlib.figure  # noqa: F401


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
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    fmt = _VECTOR_FORMAT.get()
    vector = {}
    if fmt is not None:
        import matplotlib
        out = io.BytesIO()
        metadata = {"Date": None} if fmt == "svg" else {"CreationDate": None}
        with matplotlib.rc_context({"svg.hashsalt": "actuator-design", "svg.fonttype": "path"}):
            fig.savefig(out, format=fmt, metadata=metadata)
        vector[fmt] = out.getvalue()
    return FigureBytes(buf.getvalue(), vector)


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
