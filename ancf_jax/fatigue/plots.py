"""Figures of a fatigue assessment (matplotlib, Agg): the rainflow histogram at the
hot spot and the damage along the beams."""

from __future__ import annotations

import numpy as np

from ..plotting import _finish, plt  # the project's one figure setup (Agg) and saving


def cycle_histogram(ranges, counts, *, bins: int = 30, title: str = "", path=None):
    """Histogram of rainflow cycle ranges [Pa] weighted by their counts (½ for half cycles)."""
    fig, ax = plt.subplots(figsize=(6.5, 3.6))
    r = np.asarray(ranges, float) / 1e6
    if r.size:
        ax.hist(r, bins=bins, weights=np.asarray(counts, float), color="tab:blue", alpha=0.8)
    ax.set_xlabel("stress range [MPa]")
    ax.set_ylabel("cycles")
    ax.set_yscale("log")
    if title:
        ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    return _finish(fig, path)


def damage_along(beam, s, damage_fibres, *, path=None, hot_spots=()):
    """Miner damage of both surface fibres against arc length, one curve per beam and
    fibre (log scale), hot spots marked."""
    fig, ax = plt.subplots(figsize=(7, 3.6))
    beam = np.asarray(beam)
    d = np.asarray(damage_fibres, float)
    for name in dict.fromkeys(beam.tolist()):
        m = beam == name
        o = np.argsort(s[m])
        for f, label in ((0, "+c"), (1, "−c")):
            y = np.where(d[m][o, f] > 0, d[m][o, f], np.nan)
            ax.plot(np.asarray(s)[m][o], y, marker=".", ms=3, lw=1, label=f"{name} {label}")
    for h in hot_spots[:3]:
        near = h.get("near")
        where = f" (at {near['joint']})" if near else ""
        ax.annotate(f"{h['beam']} s={h['s_m']:.2f} m{where}", (h["s_m"], h["damage"]), fontsize=7,
                    xytext=(4, 4), textcoords="offset points")
    ax.set_xlabel("arc length s [m]")
    ax.set_ylabel("damage per run [-]")
    if np.nanmax(np.where(d > 0, d, np.nan), initial=0.0) > 0:
        ax.set_yscale("log")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return _finish(fig, path)
