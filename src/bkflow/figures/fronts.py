"""Rupture fronts as pictures: the x-t and y-t maps of one slip's slip rate, and an animated GIF
of the layer through the slip (``bkflow movie``, ``Run.front_figure``, ``Run.movie``).

From the fronts a run recorded (fix bk/fronts, ``bkflow.store.rundir.RunDir.read_fronts``), never
re-computed; figures are made without pyplot (``bkflow.figures.style.Figures``). The GIF's frame
(axes in lattice units, a colour bar with its units, the title) is drawn once by matplotlib
(``front_frame_figure``); each frame pastes the layer, coloured with NumPy, into it and writes
its time with Pillow: no figure is drawn per frame.
"""

from __future__ import annotations

import math

import numpy as np

from bkflow.figures.style import Figures, PlotError, style

#: the colour map of the slip rate: blue backward, white still, red forward
CMAP = "RdBu_r"
#: the colour bar's label and the time's unit (the model's units: l, k_d, m)
RATE_LABEL = r"slip rate $v_x$ ($l\sqrt{k_d/m}$)"
TIME_UNIT = "sqrt(m/k_d)"


def run_description(spec) -> str:
    """The start and the protocol of a run, in words, for a figure's title: "random start,
    steady protocol (until steady, at most t = 1000)", "synchronized start, paper's protocol
    (t_end = 1000)", or the start and the rule when the run follows neither protocol."""
    from bkflow.model.params import STEADY_COMPANION, STEADY_START

    start, t_end = str(spec.start), f"{spec.t_end:g}"
    if spec.until_steady:
        steady = start == STEADY_START and spec.companion == STEADY_COMPANION
        rule = f"until steady, at most t = {t_end}"
        if steady:
            return f"{start} start, steady protocol ({rule})"
        beside = f" beside a {spec.companion} companion" if spec.companion else ""
        return f"{start} start{beside}, {rule}"
    if start == "synchronized" and not spec.companion:
        return f"synchronized start, paper's protocol (t_end = {t_end})"
    return f"{start} start, a fixed length (t_end = {t_end})"


def _front_maps(front, lx: int, ly: int):
    """(x-t map (S, Lx), y-t map (S, Ly)): the slip rate averaged over each column / row."""
    v = front.vx.reshape(len(front.steps), ly, lx)
    return v.mean(axis=1), v.mean(axis=2)


def front_figure(front, lx: int, ly: int, dt: float, title: str = ""):
    """The rupture front of one slip: the slip rate v_x averaged over each lattice column
    against x and t (left), over each row against y and t (right), t from the slip's stress
    maximum. A Figure (made without pyplot)."""
    xt, yt = _front_maps(front, lx, ly)
    t = (front.steps - front.step_max) * dt
    # one colour scale for both maps, from their own values (a particle's peak rate is
    # several times a column's mean)
    vmax = float(max(np.percentile(np.abs(np.concatenate([xt.ravel(), yt.ravel()])), 99.5),
                     1e-12))
    with style():
        fig, (a, b) = Figures().subplots(1, 2, figsize=(8.0, 3.4),
                                         gridspec_kw={"width_ratios": [max(lx, 8), max(ly, 8)]})
        extent_t = (t[0], t[-1]) if len(t) > 1 else (t[0], t[0] + dt)
        for ax, img, n, label in ((a, xt, lx, "column (x / l)"), (b, yt, ly, "row (y / l)")):
            im = ax.imshow(img, aspect="auto", origin="lower", cmap=CMAP, vmin=-vmax,
                           vmax=vmax, extent=(-0.5, n - 0.5, *extent_t),
                           interpolation="nearest")
            ax.set_xlabel(label)
        a.set_ylabel(r"$t - t_{\max}$ ($\sqrt{m/k_d}$)")
        fig.colorbar(im, ax=(a, b), extend="both",
                     label=RATE_LABEL + ", mean over the column / row")
        fig.suptitle(title or f"slip from step {front.step_max} to {front.step_min}"
                     + (" (truncated)" if front.truncated else ""), fontsize=9)
    return fig


def _rate_scale(front) -> float:
    """The movie's colour scale: the 99.5th percentile of |v_x| over the slip (a rate beyond
    it takes the end colour; the colour bar's pointed ends say so)."""
    return float(max(np.percentile(np.abs(front.vx), 99.5), 1e-12))


def _cell(lx: int) -> int:
    """Pixels per particle in the movie: at least ~840 pixels across (a frame read at a
    page's width), at most 24 per particle."""
    return max(2, min(24, -(-840 // lx)))


#: the frame's margins around the layer, in pixels (at 100 dpi): the title's lines and the
#: time above; the tick labels and the axis label left; below, the x axis and the colour bar
_TOP_LINE, _LEFT, _RIGHT, _BELOW_AXIS, _BAR, _BELOW_BAR = 15, 52, 30, 38, 10, 36


def front_frame_figure(front, lx: int, ly: int, dt: float, title: str = "", frame: int = 0,
                       cell: int | None = None, layer: bool = True):
    """One frame of the movie as a Figure: the layer, ``cell`` pixels per particle, coloured
    by each particle's slip rate v_x at recorded sample ``frame``, on axes in lattice units
    (x / l, y / l), with the colour bar of the whole slip's scale and its units, the title's
    lines and the frame's time. Returns (figure, (left, top) pixel of the layer's image in the
    figure drawn at 100 dpi, the pixel where the time is written); ``layer=False`` leaves the
    axes empty (the GIF pastes each frame's layer there)."""
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize
    from matplotlib.ticker import MaxNLocator

    if not 0 <= frame < len(front.steps):
        raise PlotError(f"frame {frame} not recorded; the slip has {len(front.steps)} samples")
    cell = _cell(lx) if cell is None else cell
    vmax = _rate_scale(front)
    w, h = lx * cell, ly * cell
    lines = [s for s in title.split("\n") if s] if title else []
    top = _TOP_LINE * (len(lines) + 1) + 6   # the title's lines and the time's
    bar_w = max(w, 240)                       # the colour bar under the layer, never too short
    # the layer and the bar centred in the width the title's lines and the time need
    texts = lines + [_time_text(front, len(front.steps) - 1, dt)]
    inner = max(w, bar_w, max(_text_px(t, 8.5) for t in texts) + 12 - _RIGHT)
    left = _LEFT + (inner - w) // 2
    width = _LEFT + inner + _RIGHT
    height = top + h + _BELOW_AXIS + _BAR + _BELOW_BAR
    with style():
        fig = Figures().figure(figsize=(width / 100, height / 100), layout=None, dpi=100)
        ax = fig.add_axes([left / width, 1 - (top + h) / height, w / width, h / height])
        norm = Normalize(-vmax, vmax)
        if layer:
            ax.imshow(front.vx[frame].reshape(ly, lx), origin="lower", cmap=CMAP, norm=norm,
                      extent=(-0.5, lx - 0.5, -0.5, ly - 0.5), interpolation="nearest",
                      aspect="auto")
        ax.set_xlim(-0.5, lx - 0.5)
        ax.set_ylim(-0.5, ly - 0.5)
        for axis in (ax.xaxis, ax.yaxis):
            axis.set_major_locator(MaxNLocator(nbins=6, integer=True))
        ax.tick_params(labelsize=7.5, length=3)
        ax.set_xlabel("x / l (column)", fontsize=8, labelpad=1)
        ax.set_ylabel("y / l (row)", fontsize=8, labelpad=1)
        cax = fig.add_axes([(_LEFT + (inner - bar_w) // 2) / width, _BELOW_BAR / height,
                            bar_w / width, _BAR / height])
        cb = fig.colorbar(ScalarMappable(norm=norm, cmap=CMAP), cax=cax,
                          orientation="horizontal", extend="both")
        cb.set_label(RATE_LABEL + ", each particle", fontsize=8, labelpad=1)
        cb.ax.tick_params(labelsize=7.5, length=3)
        for k, text in enumerate(lines):
            fig.text(0.5, 1 - (4 + _TOP_LINE * k) / height, text, ha="center", va="top",
                     fontsize=8.5)
        time_at = (_LEFT, 4 + _TOP_LINE * len(lines))
        if layer:
            fig.text(time_at[0] / width, 1 - time_at[1] / height, _time_text(front, frame, dt),
                     ha="left", va="top", fontsize=8.5)
    return fig, (left, top), time_at


def _text_px(text: str, size: float) -> int:
    """The width in pixels (at 100 dpi) that matplotlib gives ``text`` at ``size`` points."""
    from matplotlib.backends.backend_agg import RendererAgg
    from matplotlib.font_manager import FontProperties

    with style():
        width, _, _ = RendererAgg(10, 10, 100).get_text_width_height_descent(
            text, FontProperties(size=size), ismath="$" in text)
    return int(math.ceil(width))


def _time_text(front, frame: int, dt: float) -> str:
    t = (front.steps[frame] - front.step_max) * dt
    return f"t \u2212 t_max = {t:.2f} {TIME_UNIT}  (frame {frame + 1} of {len(front.steps)})"


def _font(size_px: int):
    """A TrueType font for the frame's time (matplotlib's DejaVu Sans, as the figure's text),
    Pillow's own where FreeType is missing."""
    from PIL import ImageFont

    try:
        from matplotlib import font_manager

        return ImageFont.truetype(font_manager.findfont("DejaVu Sans"), size_px)
    except (OSError, ImportError):
        return ImageFont.load_default()


def _palette():
    """One palette for every frame: 224 colours along the colour map and 32 greys (the
    axes, the text and its antialiasing), so that a colour means the same in every frame."""
    import matplotlib
    from PIL import Image

    ramp = matplotlib.colormaps[CMAP](np.linspace(0, 1, 224))[:, :3]
    greys = np.repeat(np.linspace(0, 1, 32)[:, None], 3, axis=1)
    colours = (np.vstack([ramp, greys]) * 255).round().astype(np.uint8)
    pal = Image.new("P", (1, 1))
    pal.putpalette(colours.ravel().tolist())
    return pal


def front_movie(front, lx: int, ly: int, dt: float, path, fps: float = 15.0,
                title: str = "", cell: int | None = None) -> int:
    """An animated GIF (Pillow) of one slip: the lattice, ``cell`` pixels per particle,
    coloured by each particle's slip rate v_x (blue backward, white still, red forward, on
    one scale through the slip), on axes in lattice units with a colour bar in the model's
    units, ``title`` (its lines) above and each frame's time; one frame per recorded sample;
    returns the number of frames. The frame is drawn once (``front_frame_figure``); each
    frame's layer is coloured with NumPy and pasted into it, in one palette for all frames."""
    import matplotlib
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from PIL import Image, ImageDraw

    if len(front.steps) == 0:
        raise PlotError("this slip has no recorded sample")
    cell = _cell(lx) if cell is None else cell
    fig, (left, top), time_at = front_frame_figure(front, lx, ly, dt, title, 0, cell,
                                                    layer=False)
    with style():
        canvas = FigureCanvasAgg(fig)
        canvas.draw()
        base = Image.fromarray(np.asarray(canvas.buffer_rgba())[..., :3].copy())
    vmax = _rate_scale(front)
    cmap = matplotlib.colormaps[CMAP]
    rgb = (cmap(np.clip(front.vx / (2 * vmax) + 0.5, 0, 1))[..., :3] * 255).astype(np.uint8)
    rgb = rgb.reshape(len(front.steps), ly, lx, 3)[:, ::-1]  # row 0 at the bottom
    rgb = rgb.repeat(cell, axis=1).repeat(cell, axis=2)
    font, pal = _font(12), _palette()
    frames = []
    for k in range(len(front.steps)):
        img = base.copy()
        img.paste(Image.fromarray(rgb[k]), (left, top))
        draw = ImageDraw.Draw(img)
        draw.rectangle((left - 1, top - 1, left + lx * cell, top + ly * cell), outline="black")
        draw.text(time_at, _time_text(front, k, dt), fill="black", font=font)
        frames.append(img.quantize(palette=pal, dither=Image.Dither.NONE))
    from bkflow.store.files import MARK, atomic_file

    with atomic_file(path, binary=True) as f:  # a full disk leaves no half GIF
        frames[0].save(f, format="GIF", save_all=True, append_images=frames[1:], loop=0,
                       duration=max(20, int(1000 / fps)), comment=MARK.encode())
    return len(frames)
