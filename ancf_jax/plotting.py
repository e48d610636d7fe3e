"""Figures of runs: time histories, stress maps, deformed shapes, trajectories,
animations. Matplotlib with the non-interactive Agg backend; every function returns
the figure and optionally saves it."""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .results import Results  # noqa: E402


def _finish(fig, path):
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=130)
        plt.close(fig)
    return fig


def time_history(t, series: dict, *, ylabel: str, title: str = "", path=None, styles=None,
                 difference: tuple[str, str] | None = None):
    """Curves over time: ``series`` maps label → values (same length as t).
    ``difference=(a, b)`` adds a panel below with series a − b (differences too small
    to see between the curves above, e.g. two curvature measures, Fig. 7)."""
    if difference is None:
        fig, ax = plt.subplots(figsize=(7, 3.6))
    else:
        fig, (ax, low) = plt.subplots(2, 1, figsize=(7, 5.4), sharex=True, height_ratios=(2, 1))
    for i, (label, y) in enumerate(series.items()):
        kw = (styles or {}).get(label, {})
        ax.plot(t, y, label=label, lw=1.2, **kw)
    ax.set_ylabel(ylabel)
    if title:
        ax.set_title(title)
    ax.grid(alpha=0.3)
    if len(series) > 1:
        ax.legend()
    if difference is not None:
        a, b = difference
        low.plot(t, np.asarray(series[a]) - np.asarray(series[b]), lw=1.0, color="k")
        low.set_ylabel("difference " + (ylabel[ylabel.rfind("["):] if "[" in ylabel else ""))
        low.set_title(f"{a} − {b}", fontsize=9)
        low.grid(alpha=0.3)
        ax = low
    ax.set_xlabel("time [s]")
    return _finish(fig, path)


def beam_curve(results: Results, beam: str, row: int, points_per_element: int = 12):
    """Centre line of a beam at output row ``row``: (x, y) arrays of sampled points."""
    b = results.system.beam_names.index(beam)
    bm = results.system.beams[b]
    n = int(bm.mesh.n_elements)
    s_nodes = np.asarray(bm.mesh.node_arc_lengths)[: n + 1]
    s = np.concatenate([np.linspace(s_nodes[k], s_nodes[k + 1], points_per_element, endpoint=k == n - 1)
                        for k in range(n)])
    import jax
    import jax.numpy as jnp
    nodes = jnp.asarray(results.nodes(beam)[row])
    xy = np.asarray(jax.vmap(lambda ss: bm.position(nodes, ss))(jnp.asarray(s)))
    return xy[:, 0], xy[:, 1]


def deformed_shapes(results: Results, beam: str, times: Sequence[float], *, bodies: Sequence[str] = (),
                    title: str = "", path=None, equal: bool = True, links=()):
    """Beam centre line (and body centres) at chosen times (paper Figs. 5 and 12).
    ``links`` are pairs of body names drawn joined by a line (e.g. a trolley and the
    cabin hanging from it); bodies are labelled by name at the first time."""
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    cmap = plt.get_cmap("viridis")
    for i, tt in enumerate(times):
        row = int(np.argmin(np.abs(results.t - tt)))
        x, y = beam_curve(results, beam, row)
        c = cmap(i / max(len(times) - 1, 1))
        ax.plot(x, y, color=c, lw=1.5, label=f"t = {results.t[row]:.2f} s")
        for a, b in links:
            pa, pb = results.body(a)[row], results.body(b)[row]
            ax.plot([pa[0], pb[0]], [pa[1], pb[1]], color=c, lw=1.0, ls=":")
        for bname in bodies:
            p = results.body(bname)[row]
            ax.plot(p[0], p[1], "s", color=c, ms=6)
            if i == 0:
                ax.annotate(bname, (p[0], p[1]), textcoords="offset points", xytext=(6, 4), fontsize=8)
    ax.set_xlabel("X [m]")
    ax.set_ylabel("Y [m]")
    if equal:
        ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    if title:
        ax.set_title(title)
    return _finish(fig, path)


def stress_map(t, s, sigma, *, title: str = "", path=None, unit: float = 1e6, label="MPa"):
    """Stress along a beam over time as a colour map (paper Fig. 8).

    Args:
        t: times [s], shape (N,).
        s: arc lengths [m], shape (E, P).
        sigma: stresses [Pa], shape (N, E, P).
    """
    ss = np.asarray(s).ravel()
    keep = np.isfinite(ss)
    order = np.argsort(ss[keep], kind="stable")
    sv = ss[keep][order]
    sig = np.asarray(sigma).reshape(len(t), -1)[:, keep][:, order] / unit
    fig, ax = plt.subplots(figsize=(7, 3.8))
    vmax = np.nanmax(np.abs(sig)) or 1.0
    mesh = ax.pcolormesh(t, sv, sig.T, cmap="RdBu_r", vmin=-vmax, vmax=vmax, shading="nearest")
    fig.colorbar(mesh, ax=ax, label=f"bending stress [{label}]")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("arc length s [m]")
    if title:
        ax.set_title(title)
    return _finish(fig, path)


def trajectories(curves: dict, *, title: str = "", path=None, xlabel="X [m]", ylabel="Y [m]",
                 t=None, reference: str | None = None):
    """Planar trajectories: ``curves`` maps label → (x, y) (paper Fig. 13). With the
    common sample times ``t`` and a ``reference`` label (e.g. the finest mesh), a panel
    below shows each other curve's distance from the reference over time [mm]: the
    differences between meshes are millimetres on a metre-sized plot."""
    if reference is None:
        fig, ax = plt.subplots(figsize=(6.5, 4.2))
    else:
        fig, (ax, low) = plt.subplots(2, 1, figsize=(6.5, 6.4), height_ratios=(2, 1))
    for label, (x, y) in curves.items():
        ax.plot(x, y, lw=1.3, label=label)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
    ax.legend()
    if title:
        ax.set_title(title)
    if reference is not None:
        xr, yr = (np.asarray(a) for a in curves[reference])
        for label, (x, y) in curves.items():
            if label != reference:
                k = min(len(x), len(xr), len(t))
                low.plot(t[:k], 1e3 * np.hypot(np.asarray(x)[:k] - xr[:k], np.asarray(y)[:k] - yr[:k]),
                         lw=1.1, label=label)
        low.set_xlabel("time [s]")
        low.set_ylabel(f"distance from {reference} [mm]")
        low.grid(alpha=0.3)
        low.legend(fontsize=8)
    return _finish(fig, path)


def animate(results: Results, beam: str, path, *, bodies: Sequence[str] = (), links=(), fps: int = 25,
            stride: int | None = None, title: str = ""):
    """Animation of a beam and bodies (GIF with Pillow; MP4 if ffmpeg is available and the
    path ends in .mp4). ``links`` are pairs of body names drawn as lines."""
    from matplotlib import animation
    n = len(results.t)
    if stride is None:
        dt = float(results.t[1] - results.t[0]) if n > 1 else 1.0
        stride = max(1, int(round(1.0 / (fps * dt))))
    rows = list(range(0, n, stride))
    xs, ys = [], []
    for r in rows:
        x, y = beam_curve(results, beam, r, 8)
        xs.append(x)
        ys.append(y)
    allx = np.concatenate(xs + [results.body(b)[:, 0] for b in bodies])
    ally = np.concatenate(ys + [results.body(b)[:, 1] for b in bodies])
    fig, ax = plt.subplots(figsize=(6, 4.5))
    pad = 0.05 * max(np.ptp(allx), np.ptp(ally), 1e-3)
    ax.set_xlim(allx.min() - pad, allx.max() + pad)
    ax.set_ylim(ally.min() - pad, ally.max() + pad)
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    (line,) = ax.plot([], [], "b-", lw=2)
    marks = [ax.plot([], [], "s", ms=9)[0] for _ in bodies]
    link_lines = [ax.plot([], [], "k-", lw=1)[0] for _ in links]
    label = ax.text(0.02, 0.95, "", transform=ax.transAxes)
    if title:
        ax.set_title(title)

    def update(i):
        r = rows[i]
        line.set_data(xs[i], ys[i])
        for m, b in zip(marks, bodies):
            p = results.body(b)[r]
            m.set_data([p[0]], [p[1]])
        for ln, (a, b) in zip(link_lines, links):
            pa, pb = results.body(a)[r], results.body(b)[r]
            ln.set_data([pa[0], pb[0]], [pa[1], pb[1]])
        label.set_text(f"t = {results.t[r]:.2f} s")
        return [line, *marks, *link_lines, label]

    anim = animation.FuncAnimation(fig, update, frames=len(rows), blit=True)
    path = Path(path)
    if path.suffix == ".mp4" and animation.writers.is_available("ffmpeg"):
        anim.save(path, writer=animation.FFMpegWriter(fps=fps))
    else:
        path = path.with_suffix(".gif")
        anim.save(path, writer=animation.PillowWriter(fps=fps))
    plt.close(fig)
    return path


def pantograph_figures(run, out_dir) -> None:
    """Figures of a pantograph–catenary run (:func:`ancf_jax.reports.report_pantograph`):
    ``contact_force.png`` (raw and filtered along the track, the evaluated window
    shaded), ``uplift.png`` (contact wire at the evaluated poles vs the pantograph's
    position) and ``dropper_slack.png`` (slack droppers, by position, vs the
    pantograph's position)."""
    out = Path(out_dir)
    fig, ax = plt.subplots(figsize=(9, 3.5))
    ax.axvspan(*run.window, color="0.92", label="evaluated")
    ax.plot(run.x, run.force, lw=0.6, color="0.6", label="contact force")
    ax.plot(run.x, run.filtered, lw=1.2, color="C0", label="filtered (20 Hz)")
    ax.set_xlabel("pantograph position x [m]")
    ax.set_ylabel("contact force [N]")
    ax.legend(loc="upper right", fontsize=8)
    _finish(fig, out / "contact_force.png")
    fig, ax = plt.subplots(figsize=(9, 3.5))
    for j in range(run.uplift.shape[1]):
        ax.plot(run.x, 1e3 * run.uplift[:, j], lw=1.0, label=f"pole {j + 1}")
    ax.set_xlabel("pantograph position x [m]")
    ax.set_ylabel("contact wire uplift [mm]")
    ax.legend(fontsize=8)
    _finish(fig, out / "uplift.png")
    system = run.results.system
    sets = [f for f in system.forces if f.name == "catenary.droppers"]
    if sets:
        drop = sets[0]
        slack = run.results.members(drop.name)[:, :, 1] < 0.5
        q0 = np.asarray(run.results.q[0])
        xd = q0[np.asarray(drop.member_coordinates(system, q0))[:, 0]]
        fig, ax = plt.subplots(figsize=(9, 3.5))
        ii, jj = np.nonzero(slack)
        ax.scatter(run.x[ii], xd[jj], s=2, color="C3")
        ax.set_xlabel("pantograph position x [m]")
        ax.set_ylabel("slack dropper at x [m]")
        ax.set_title(f"slack droppers ({int(slack.any(axis=0).sum())} of {len(drop.names)} go slack)")
        _finish(fig, out / "dropper_slack.png")
