"""Rupture fronts as pictures: the x-t and y-t maps of one slip's slip rate, and an animated GIF
of the layer through the slip (``bkflow movie``, ``Run.front_figure``, ``Run.movie``).

From the fronts a run recorded (fix bk/fronts, ``bkflow.rundir.RunDir.read_fronts``), never
re-computed; figures are made without pyplot (``bkflow.plot.Figures``), the GIF with
Pillow from NumPy-coloured frames.
"""

from __future__ import annotations

import numpy as np

from .plot import Figures, PlotError, style


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
            im = ax.imshow(img, aspect="auto", origin="lower", cmap="RdBu_r", vmin=-vmax,
                           vmax=vmax, extent=(-0.5, n - 0.5, *extent_t),
                           interpolation="nearest")
            ax.set_xlabel(label)
        a.set_ylabel(r"$t - t_{\max}$ ($\sqrt{m/k_d}$)")
        fig.colorbar(im, ax=(a, b), label=r"slip rate $v_x$ ($l\sqrt{k_d/m}$), mean over the "
                     "column / row")
        fig.suptitle(title or f"slip from step {front.step_max} to {front.step_min}"
                     + (" (truncated)" if front.truncated else ""))
    return fig


def front_movie(front, lx: int, ly: int, dt: float, path, fps: float = 15.0,
                title: str = "", cell: int | None = None) -> int:
    """An animated GIF (Pillow) of one slip: the lattice, ``cell`` pixels per particle,
    coloured by each particle's slip rate v_x (blue backward, white still, red forward, on
    one scale through the slip), one frame per recorded sample, a caption with the time;
    returns the number of frames. Frames are coloured with NumPy (a matplotlib colormap) and
    written by Pillow: no figure is drawn per frame."""
    import matplotlib
    from PIL import Image, ImageDraw

    if len(front.steps) == 0:
        raise PlotError("this slip has no recorded sample")
    if cell is None:  # at least ~480 pixels across, at most 24 per particle
        cell = max(2, min(24, -(-480 // lx)))
    vmax = float(max(np.percentile(np.abs(front.vx), 99.5), 1e-12))
    cmap = matplotlib.colormaps["RdBu_r"]
    rgb = (cmap(np.clip(front.vx / (2 * vmax) + 0.5, 0, 1))[..., :3] * 255).astype(np.uint8)
    rgb = rgb.reshape(len(front.steps), ly, lx, 3)[:, ::-1]  # row 0 at the bottom
    rgb = rgb.repeat(cell, axis=1).repeat(cell, axis=2)
    caption = 16
    frames = []
    for k, step in enumerate(front.steps):
        img = Image.new("RGB", (rgb.shape[2], rgb.shape[1] + caption), "white")
        img.paste(Image.fromarray(rgb[k]), (0, caption))
        ImageDraw.Draw(img).text(
            (3, 2), f"{title}t - t_max = {(step - front.step_max) * dt:6.2f} sqrt(m/k_d)   "
            f"v_x: blue {-vmax:.2g} .. red {vmax:.2g} l sqrt(k_d/m)", fill="black")
        frames.append(img.convert("P", palette=Image.Palette.ADAPTIVE, colors=64))
    from .io import MARK, atomic_file

    with atomic_file(path, binary=True) as f:  # a full disk leaves no half GIF
        frames[0].save(f, format="GIF", save_all=True, append_images=frames[1:], loop=0,
                       duration=max(20, int(1000 / fps)), comment=MARK.encode())
    return len(frames)
