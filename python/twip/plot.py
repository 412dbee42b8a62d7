"""Figures for simulation results and sweeps (matplotlib, imported only when called).

    import twip, twip.plot
    sc = twip.scenarios.get("slope-lqr")
    twip.plot.result(sc.run(), scenario=sc, path="slope-lqr.png")   # the layout fits the model

Everything is in degrees, metres and seconds on the axes; the inputs are in SI (radians).
Each function returns a `matplotlib.figure.Figure`. With `path=` it also writes the file
(a bare Agg figure: no display needed, not registered with pyplot, so scripts that make
hundreds of figures do not leak them; PNGs are full colour at 150 dpi, and
`COMPACT_PNG = True` re-encodes them with a 128-colour palette, a third of the size);
without, the figure is pyplot's, for notebooks and `plt.show()`.

`pip install twip[plot]` installs matplotlib and Pillow.

One file because every figure shares the same private layout helpers (`_styled`, `_figure`,
`_grid`, `_legend`, `_line`, `_finish`): split, they would have to become public API that no
user needs. The figures are grouped run, tracking, sweep, tables, in that order.
"""
from __future__ import annotations

import math
import os
from typing import Mapping, Optional, Sequence

import numpy as np

from twip import _core

#: Colours: ours, the reference, the target pitch, measured signals, extra series.
OURS, REF, TARGET, MEASURED = "#1f5fa8", "#222222", "#c0392b", "#9aa5b1"
RIG = "#e67e22"  # a second run beside ours: the same scenario with the thesis-like robot in the loop
PALETTE = ("#1f5fa8", "#e67e22", "#27ae60", "#8e44ad", "#c0392b", "#16a085", "#7f8c8d", "#d35400", "#2c3e50")

_STYLE = {
    "font.size": 8.5,
    "axes.titlesize": 9,
    "axes.labelsize": 8.5,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "grid.linewidth": 0.6,
    "legend.fontsize": 7.5,
    "legend.framealpha": 0.85,
    "lines.linewidth": 1.3,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "figure.dpi": 100,
    # 150: the dots of φ̇, θ̇ and the subscripts stay legible (at 100 they vanish).
    "savefig.dpi": 150,
}


def style(dpi=None) -> dict:
    """twip's matplotlib style (rc parameters); `style(dpi=60)` sets the resolution of the
    figures written from now on and returns the style as it was before."""
    before = dict(_STYLE)
    if dpi is not None:
        if not (isinstance(dpi, (int, float)) and 1 <= dpi <= 2400):
            raise ValueError(f"dpi must be a number from 1 to 2400, got {dpi!r}")
        _STYLE["savefig.dpi"] = dpi
    return before


def _mpl():
    try:
        import matplotlib
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("twip.plot needs matplotlib: pip install 'twip[plot]'") from e
    return matplotlib


def use_agg() -> None:
    """Selects the Agg backend unless pyplot is already running with another one."""
    import sys

    matplotlib = _mpl()
    if "matplotlib.pyplot" not in sys.modules:
        matplotlib.use("Agg")


def _styled(function):
    """Runs a figure-making function inside twip's matplotlib style."""
    import functools

    @functools.wraps(function)
    def wrapper(*args, **kw):
        with _mpl().rc_context(_STYLE):
            return function(*args, **kw)

    return wrapper


def _figure(figsize, path):
    """A Figure: a bare one (Agg canvas) when it is only written to a file, else pyplot's."""
    _mpl()
    if path is not None:
        from matplotlib.figure import Figure

        return Figure(figsize=figsize)
    import matplotlib.pyplot as plt

    return plt.figure(figsize=figsize)


def _wrap(title: str, width_in: float, size: float = 10.0) -> str:
    """Wraps each line of a bold title to the figure's width."""
    import textwrap

    chars = max(30, int(width_in * 72 / (0.66 * size)))
    return "\n".join(textwrap.fill(line, chars) for line in title.split("\n"))


def _finish(fig, path, title=None):
    if title:
        fig.suptitle(_wrap(title, fig.get_size_inches()[0]), fontsize=10, fontweight="bold", x=0.01, y=0.995,
                     ha="left", va="top")
    if path is not None:
        save(fig, path)
    return fig


@_styled
def warm_up() -> None:
    """Draws a throw-away figure with text in every style used, so that matplotlib's font
    cache and glyphs are loaded (before forking workers that then share them)."""
    import io

    fig = _figure((2, 1), path="-")
    ax = _axes(fig, 1, 1, 1)
    ax.plot([0, 1], [0, 1], label="φ θ̇ ψ̇ Ŝ − ±°")
    ax.set_title("warm up", fontweight="bold")
    ax.legend()
    fig.suptitle("warm up", fontweight="bold")
    fig.savefig(io.BytesIO(), format="png")


#: Set True to write PNGs with a 128-colour palette (Pillow): a third of the size, but
#: blended colours (lines over fills, antialiased text) lose their shades.
COMPACT_PNG = False


def check_folder(path) -> None:
    """Refuses an output path that is a folder, or whose folder does not exist or cannot
    be written, before the work whose result it would hold."""
    path = os.fspath(path)
    if os.path.isdir(path):
        raise _core.InvalidParameterError(f"output {str(path)!r}: is a folder, not a file")
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise _core.InvalidParameterError(f"output {str(path)!r}: the folder {folder} does not exist")
    if not os.access(folder, os.W_OK):
        raise _core.InvalidParameterError(f"output {str(path)!r}: the folder {folder} is not writable")


def check_path(path) -> None:
    """Refuses, before a run, a figure path matplotlib cannot write: a missing or
    unwritable folder, or a file type it does not know (e.g. .txt)."""
    from matplotlib.backend_bases import FigureCanvasBase

    check_folder(path)
    known = FigureCanvasBase.get_supported_filetypes()
    ext = os.path.splitext(os.fspath(path))[1].lower().lstrip(".")
    if ext not in known:
        raise _core.InvalidParameterError(
            f"figure path {str(path)!r}: '.{ext}' is not a figure format; use one of "
            f"{', '.join('.' + k for k in sorted(known))}")


def save(fig, path) -> None:
    """fig.savefig(path); with `COMPACT_PNG` a .png is re-encoded with a palette when Pillow is there."""
    check_path(path)
    if not (COMPACT_PNG and str(path).lower().endswith(".png")):
        fig.savefig(path)
        return
    try:
        from PIL import Image
    except ImportError:
        fig.savefig(path)
        return
    import io

    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    buf.seek(0)
    with Image.open(buf) as im:
        im.convert("RGB").quantize(colors=128, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE).save(
            path, optimize=True)


def _axes(fig, *args, **kw):
    return fig.add_subplot(*args, **kw)


def _grid(fig, rows, cols, left=0.75, right=0.25, top=0.7, bottom=0.5, **kw):
    """A GridSpec with margins in inches (the figures are laid out once, no tight bbox)."""
    w, h = fig.get_size_inches()
    return fig.add_gridspec(rows, cols, left=left / w, right=1 - right / w, top=1 - top / h, bottom=bottom / h, **kw)


def _legend(ax, outside=False, **kw):
    handles, labels = ax.get_legend_handles_labels()
    if handles:
        if outside:
            kw = {"loc": "upper left", "bbox_to_anchor": (1.01, 1.0), "borderaxespad": 0.0, **kw}
        ax.legend(**{"loc": "best", **kw})


def _thin(t, y, buckets: int = 1500):
    """About 2·buckets points keeping each bucket's minimum and maximum in time order (a
    line drawn from them looks like the full one, spikes included, and draws much faster)."""
    t, y = np.asarray(t), np.asarray(y)
    n = len(t)
    if n <= 2 * buckets:
        return t, y
    m = n // buckets
    head = y[: m * buckets].reshape(buckets, m)
    lo, hi = np.argmin(head, axis=1), np.argmax(head, axis=1)
    idx = np.sort(np.stack([lo, hi], axis=1), axis=1) + (np.arange(buckets) * m)[:, None]
    tail = y[m * buckets:]
    rest = np.unique([np.argmin(tail), np.argmax(tail), len(tail) - 1]) + m * buckets if len(tail) else np.zeros(0, int)
    idx = np.concatenate([idx.ravel(), rest.astype(idx.dtype)])
    return t[idx], y[idx]


def _line(ax, t, y, *args, **kw):
    return ax.plot(*_thin(t, y), *args, **kw)


def _robust_ylim(ax, *series, factor=4.0):
    """Keeps a brief start-up spike from flattening the rest of a panel: when the extreme
    values lie far outside the 1-99 % range, the axis shows that range (with a margin) and
    notes the clipped peak."""
    data = np.concatenate([np.asarray(s, float).ravel() for s in series])
    data = data[np.isfinite(data)]
    if len(data) < 20:
        return
    lo, hi = np.quantile(data, (0.01, 0.99))
    span = max(hi - lo, 1e-12)
    if data.min() < lo - factor * span or data.max() > hi + factor * span:
        ax.set_ylim(lo - 0.6 * span, hi + 0.6 * span)
        peak = data[np.argmax(np.abs(data))]
        # On a white box above the lines: a clipped spike must not run through the number.
        ax.text(0.99, 0.03, f"peak {peak:.3g} off scale", transform=ax.transAxes, ha="right", va="bottom",
                fontsize=7, color="#666666", zorder=10,
                bbox={"boxstyle": "square,pad=0.2", "facecolor": "white", "edgecolor": "none"})


def _is_planar(result) -> bool:
    return result.states.shape[1] == 7


def _title(scenario, default):
    if scenario is not None:
        return f"{scenario.name}: {scenario.description}"
    return default


# ----------------------------------------------------------------------------- one run


@_styled
def result(result, scenario=None, path=None, title=None, internals: bool = True):
    """The usual figure for one run: `timeseries` (2-DOF) or `tracking` (3-DOF)."""
    if _is_planar(result):
        return tracking(result, scenario=scenario, path=path, title=title, internals=internals)
    return timeseries(result, scenario=scenario, path=path, title=title, internals=internals)


def _phi_s(result, scenario):
    """The pitch the controller aims at per sample [rad], or the plant's steady pitch."""
    if "phi_s" in result.internals:
        return result.internals["phi_s"], r"$\varphi_s$ (controller's target)"
    if scenario is not None and hasattr(scenario.model, "equilibrium"):
        ref = result.reference("theta_dot")
        values = {}
        out = np.empty_like(ref)
        for i, w in enumerate(ref):
            if w not in values:
                values[w] = scenario.model.equilibrium(float(w))[0][0]
            out[i] = values[w]
        return out, r"$\varphi_s$ (steady pitch)"
    return None, None


@_styled
def _beside(ax, beside, of) -> None:
    """Draws `beside` = (label, run)'s signal `of(run)` thin, behind ours (nothing if None)."""
    if beside is not None:
        label, run = beside
        _line(ax, run.t, of(run), color=RIG, lw=0.8, alpha=0.85, label=label, zorder=1)


def _mark_ours_only(fig, beside) -> None:
    """With a run `beside` ours, the panels that draw ours alone say so in their title (their
    colours are not that run's)."""
    if beside is None:
        return
    for a in fig.axes:
        title = a.get_title()
        if a.get_visible() and title and not any(line.get_label() == beside[0] for line in a.get_lines()):
            a.set_title(f"{title} (ideal plant only)", fontsize=a.title.get_fontsize())


def timeseries(result, scenario=None, path=None, title=None, internals: bool = True, beside=None):
    """A 2-DOF run (SlopeModel): pitch with its target φ_s, pitch rate, wheel speed with its
    reference, distance with the reference position, the input current and the
    controller's internals (the fuzzy weights Ŝ, or the LQR integrator). `beside` = (label,
    run): a second run of the same scenario drawn beside ours on the first four panels."""
    t = result.t
    deg = np.degrees
    phi, phi_dot, theta, theta_dot = result.states.T
    radius = scenario.model.params.wheel_radius if scenario is not None else None
    rows = 3 if internals else 2
    fig = _figure((11, 2.45 * rows + 0.4), path)
    gs = _grid(fig, rows, 2, right=0.7, hspace=0.5, wspace=0.2)

    ax = _axes(fig, gs[0, 0])
    sig = getattr(result, "signals", None) or {}
    if "phi_hat" in sig:  # with twip.Realism: what the controller read
        _line(ax, t, deg(sig["phi_hat"]), color=MEASURED, lw=0.8, label="measured φ̂")
    _line(ax, t, deg(phi), color=OURS, label="pitch φ")
    _beside(ax, beside, lambda r: deg(r.states[:, 0]))
    target, label = _phi_s(result, scenario)
    if target is not None:
        _line(ax, t, deg(target), color=TARGET, ls="--", lw=1.1, label=label)
    thesis = getattr(scenario, "thesis", None) or {}
    if "phi_s_deg" in thesis:  # the thesis's own values, to read ours against
        ax.axhline(thesis["phi_s_deg"], color=REF, ls=":", lw=1.0, label=rf"thesis $\varphi_s$ = {thesis['phi_s_deg']:g}°")
    if "pitch_settling_time" in thesis:
        ax.axvline(thesis["pitch_settling_time"], color=REF, ls=":", lw=1.0,
                   label=f"thesis: settled by {thesis['pitch_settling_time']:g} s")
    ax.set(ylabel="pitch [deg]", title="Body pitch")
    _legend(ax)

    ax = _axes(fig, gs[0, 1])
    _line(ax, t, deg(phi_dot), color=OURS, label=r"pitch rate $\dot\varphi$")
    _beside(ax, beside, lambda r: deg(r.states[:, 1]))
    ax.axhline(0.0, color=REF, ls="--", lw=1.0, label="reference 0")
    if "pitch_rate_settling_time" in thesis:
        ax.axvline(thesis["pitch_rate_settling_time"], color=REF, ls=":", lw=1.0,
                   label=f"thesis: settled by {thesis['pitch_rate_settling_time']:g} s")
    ax.set(ylabel="pitch rate [deg/s]", title="Body pitch rate")
    _legend(ax)

    ax = _axes(fig, gs[1, 0])
    if "theta_dot_hat" in sig:
        _line(ax, t, deg(sig["theta_dot_hat"]), color=MEASURED, lw=0.8, label=r"measured $\hat{\dot\theta}$")
    _line(ax, t, deg(theta_dot), color=OURS, label=r"wheel speed $\dot\theta$")
    _beside(ax, beside, lambda r: deg(r.states[:, 3]))
    if "theta_dot" in result.reference_names:
        _line(ax, t, deg(result.reference("theta_dot")), color=REF, ls="--", lw=1.1, label=r"reference $\dot\theta_\mathrm{ref}$")
    if "speed_settling_time" in thesis:
        ax.axvline(thesis["speed_settling_time"], color=REF, ls=":", lw=1.0,
                   label=f"thesis: settled by {thesis['speed_settling_time']:g} s")
    ax.set(ylabel="wheel speed [deg/s]", title="Wheel speed")
    _legend(ax)

    ax = _axes(fig, gs[1, 1])
    scale, unit = (radius, "m") if radius else (1.0, "rad")
    _line(ax, t, theta * scale, color=OURS, label="travelled " + (r"$\theta r$" if radius else r"$\theta$"))
    _beside(ax, beside, lambda r: r.states[:, 2] * scale)
    if "theta" in result.reference_names:
        _line(ax, t, result.reference("theta") * scale, color=REF, ls="--", lw=1.1, label="reference")
    ax.set(ylabel=f"position [{unit}]", title="Position along the ground")
    _legend(ax, loc="best")

    if internals:
        ax = _axes(fig, gs[2, 0])
        if "motor_current" in sig:
            _line(ax, t, sig["motor_current"], color=PALETTE[1], lw=0.6, alpha=0.6, label="motor current (driver)")
        _line(ax, t, result.inputs[:, 0], color=OURS, lw=1.0, label="commanded u")
        if "motor_current" in sig:
            _legend(ax)
        _robust_ylim(ax, result.inputs[:, 0])
        ax.set(ylabel="motor current [A]", xlabel="time [s]", title="Input (lumped motor current)")
        ax = _axes(fig, gs[2, 1])
        controller_internals(result, ax=ax)
        ax.set_xlabel("time [s]")
    else:
        for a in fig.axes[-2:]:
            a.set_xlabel("time [s]")
    for a in fig.axes:
        a.set_xlim(t[0], t[-1])
    if result.fell:
        for a in fig.axes:
            a.axvline(result.t_end, color=TARGET, lw=0.8)
        fig.axes[0].text(result.t_end, 0.02, " fell", color=TARGET, transform=fig.axes[0].get_xaxis_transform())
    _mark_ours_only(fig, beside)
    return _finish(fig, path, title or _title(scenario, "2-DOF run"))


def _shades(n: int) -> list:
    """n colours that a reader tells apart, in order (viridis, without its palest end)."""
    from matplotlib import colormaps

    cmap = colormaps["viridis"]
    return [cmap(0.85 * i / max(n - 1, 1)) for i in range(n)]


@_styled
def controller_internals(result, ax=None, names: Optional[Sequence[str]] = None, path=None):
    """The controller's logged internals on one axis: fuzzy weights Ŝ1…Ŝ9 (2-DOF fuzzy),
    sliding surfaces S1, S_η (sliding mode), the PID terms, or the LQR integrator z."""
    own = ax is None
    if own:
        fig = _figure((6, 3), path)
        ax = _axes(fig, 1, 1, 1)
    t = result.t
    inner = result.internals
    if names is None:
        if "S1" in inner:  # fuzzy backstepping: the adaptive weights
            names = [n for n in (f"S{i}" for i in range(1, 10)) if n in inner]
            title, ylabel = r"Fuzzy weights $\hat S$ (adaptive estimate of $F_1$)", r"$\hat S_k$ [rad/s²]"
        elif "s1" in inner:  # sliding mode
            names = ["s1", "s_eta"]
            # S_η = ω − λ3 [rad/s]; S1 = r1 (φ̇ − λ1) + r2 (v − λ2) with the thesis's unitless r1, r2.
            title, ylabel = "Sliding surfaces", r"$S_\eta$ [rad/s]; $S_1$ [$r_1$ rad/s + $r_2$ m/s]"
        elif "u_phi" in inner:  # PID tracker
            names = ["u_phi", "u_v", "u_psi"]
            title, ylabel = "PID terms (PWM counts)", "counts"
        elif "z" in inner:
            names = ["z"]
            title, ylabel = r"LQR integrator $\int(\dot\theta - \dot\theta_\mathrm{ref})\,dt$", "z [rad]"
        else:
            names = list(inner)[:6]
            title, ylabel = "Controller internals", ""
    else:
        title, ylabel = "Controller internals", ""
    pretty = {"s1": "$S_1$", "s_eta": r"$S_\eta$", "u_phi": r"$u_\varphi$", "u_v": "$u_v$", "u_psi": r"$u_\psi$",
              "z": "$z$"}
    weights = [n for n in names if n.startswith("S") and n[1:].isdigit()]
    # Nine weights: nine distinct colours along a sequential map, each in the legend.
    shades = _shades(len(weights))
    for i, n in enumerate(names):
        if n in weights:
            label, colour = rf"$\hat S_{{{n[1:]}}}$", shades[weights.index(n)]
        else:
            label, colour = pretty.get(n, n), PALETTE[i % len(PALETTE)]
        _line(ax, t, inner[n], color=colour, lw=1.0, label=label)
    if names:
        _robust_ylim(ax, *[inner[n] for n in names])
    ax.set(title=title, ylabel=ylabel)
    if names:
        _legend(ax, outside=len(names) > 4)
    if own:
        ax.set_xlabel("time [s]")
        return _finish(ax.figure, path)
    return ax


def _ref_xy(result):
    return result.reference("x"), result.reference("y")


def _path_error(result, trajectory=None):
    """Distance to the moving reference point and, when the trajectory is known, to the path [m]."""
    x, y = result.states[:, 0], result.states[:, 1]
    xr, yr = _ref_xy(result)
    to_point = np.hypot(x - xr, y - yr)
    to_path = None
    if trajectory is not None and hasattr(trajectory, "distance"):
        to_path = np.array([trajectory.distance(float(a), float(b)) for a, b in zip(x, y)])
    return to_point, to_path


@_styled
def xy_path(results, ax=None, path=None, title=None):
    """x–y paths of one or more 3-DOF runs against the reference. `results` is a SimResult
    or {label: SimResult}; the first one's reference is drawn."""
    if not isinstance(results, Mapping):
        results = {"robot": results}
    own = ax is None
    if own:
        fig = _figure((5.5, 5.2), path)
        ax = _axes(fig, 1, 1, 1)
    first = next(iter(results.values()))
    xr, yr = _ref_xy(first)
    step = max(1, len(xr) // 4000)
    ax.plot(xr[::step], yr[::step], color=REF, ls="--", lw=1.0, label="reference", zorder=5)
    styles = ("-", "--", ":", "-.")
    for i, (label, r) in enumerate(results.items()):
        step = max(1, len(r.t) // 4000)
        ax.plot(r.states[::step, 0], r.states[::step, 1], color=PALETTE[i % len(PALETTE)],
                ls=styles[(i // len(PALETTE)) % 4], lw=1.4, label=label)
    ax.plot([first.states[0, 0]], [first.states[0, 1]], "o", color=REF, ms=5, label="start")
    ax.set(xlabel="x [m]", ylabel="y [m]", title="Path (top view)")
    ax.set_aspect("equal", adjustable="datalim")
    _legend(ax, loc="center")
    if own:
        return _finish(ax.figure, path, title)
    return ax


@_styled
def paths(results: Mapping, trajectory=None, path=None, title=None):
    """Figure: x–y paths of several runs against the reference (left) and their distance to
    the reference point and to the path itself over time (right)."""
    fig = _figure((11, 4.6), path)
    gs = _grid(fig, 2, 2, width_ratios=(1.0, 1.3), hspace=0.45, wspace=0.2)
    xy_path(results, ax=_axes(fig, gs[:, 0]))
    ax1, ax2 = _axes(fig, gs[0, 1]), _axes(fig, gs[1, 1])
    for i, (label, r) in enumerate(results.items()):
        to_point, to_path = _path_error(r, trajectory)
        _line(ax1, r.t, 100 * to_point, color=PALETTE[i % len(PALETTE)], label=label)
        if to_path is not None:
            _line(ax2, r.t, 100 * to_path, color=PALETTE[i % len(PALETTE)], label=label)
    ax1.set(ylabel="[cm]", title="Distance to the moving reference point")
    ax2.set(ylabel="[cm]", xlabel="time [s]", title="Distance to the path (the circle itself)")
    if trajectory is None:
        ax2.set_visible(False)
    from matplotlib.ticker import FuncFormatter

    for a in (ax1, ax2):
        a.set_yscale("symlog", linthresh=0.1, linscale=0.5)
        a.set_ylim(bottom=0)
        a.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        _legend(a, loc="upper right")
    return _finish(fig, path, title)


@_styled
def tracking(result, scenario=None, path=None, title=None, internals: bool = True, show_path: bool = True,
             beside=None):
    """A 3-DOF run (PlanarModel): the x–y path against the reference, pitch (with φ_s when
    the controller has one), forward speed and yaw rate against their references, the
    distance to the reference, the wheel torques and the controller's internals (sliding
    surfaces S1, S_η and fuzzy weights, or the PID terms). `beside` = (label, run): a second
    run of the same scenario drawn beside ours on the path, pitch, speed and yaw rate."""
    t = result.t
    deg = np.degrees
    x, y, psi, phi, phi_dot, v, omega = result.states.T
    inner = result.internals
    fig = _figure((12, 7.6 if internals else 5.2), path)
    rows = 3 if internals else 2
    gs = _grid(fig, rows, 3, right=0.7, hspace=0.5, wspace=0.3)
    panels = []
    if show_path:
        xy_path({"robot": result, **({beside[0]: beside[1]} if beside else {})}, ax=_axes(fig, gs[:2, 0]))
        slots = [gs[0, 1], gs[0, 2], gs[1, 1], gs[1, 2]] + ([gs[2, 0], gs[2, 1], gs[2, 2]] if internals else [])
    else:
        slots = [gs[i, j] for i in range(rows) for j in range(3)]

    ax = _axes(fig, slots[0])
    _line(ax, t, deg(phi), color=OURS, label="pitch φ")
    _beside(ax, beside, lambda r: deg(r.states[:, 3]))
    if "phi_s" in inner:
        _line(ax, t, deg(inner["phi_s"]), color=TARGET, ls="--", lw=1.1, label=r"$\varphi_s$ (controller's target)")
    else:
        ax.axhline(0.0, color=REF, ls="--", lw=1.0, label="upright")
    ax.set(ylabel="pitch [deg]", title="Body pitch")
    _legend(ax)
    panels.append(ax)

    ax = _axes(fig, slots[1])
    _line(ax, t, v, color=OURS, label="v")
    _beside(ax, beside, lambda r: r.states[:, 5])
    _line(ax, t, result.reference("v"), color=REF, ls="--", lw=1.1, label=r"$v_\mathrm{ref}$")
    ax.set(ylabel="speed [m/s]", title="Forward speed")
    _legend(ax)
    panels.append(ax)

    ax = _axes(fig, slots[2])
    _line(ax, t, deg(omega), color=OURS, label=r"$\omega = \dot\psi$")
    _beside(ax, beside, lambda r: deg(r.states[:, 6]))
    _line(ax, t, deg(result.reference("omega")), color=REF, ls="--", lw=1.1, label=r"$\omega_\mathrm{ref}$")
    ax.set(ylabel="yaw rate [deg/s]", title="Yaw rate")
    _legend(ax)
    panels.append(ax)

    ax = _axes(fig, slots[3])
    xr, yr = _ref_xy(result)
    _line(ax, t, 100 * (x - xr), color=PALETTE[0], label=r"$x - x_r$")
    _line(ax, t, 100 * (y - yr), color=PALETTE[1], label=r"$y - y_r$")
    ax.set(ylabel="[cm]", title="Position error")
    _legend(ax)
    panels.append(ax)

    if internals:
        ax = _axes(fig, slots[4])
        _line(ax, t, result.inputs[:, 0], color=PALETTE[0], lw=1.0, label=r"$u_r$")
        _line(ax, t, result.inputs[:, 1], color=PALETTE[1], lw=1.0, label=r"$u_l$")
        _robust_ylim(ax, result.inputs[:, 0], result.inputs[:, 1])
        ax.set(ylabel="torque [N m]", title="Wheel torques")
        _legend(ax)
        panels.append(ax)
        ax = _axes(fig, slots[5])
        controller_internals(result, ax=ax)
        panels.append(ax)
        ax = _axes(fig, slots[6])
        weights = [n for n in inner if n.startswith("c1_")] + [n for n in inner if n.startswith("c2_")]
        if weights and np.any([np.any(inner[n] != 0) for n in weights]):
            # Eighteen weights read as a heat map over time: one row each, Ĉ1's above Ĉ2's.
            table = np.array([inner[n] for n in weights])
            reach = float(np.max(np.abs(table))) or 1.0
            image = ax.imshow(table, aspect="auto", cmap="RdBu_r", vmin=-reach, vmax=reach, interpolation="nearest",
                              extent=(t[0], t[-1], len(weights) - 0.5, -0.5))
            ax.set_yticks(range(len(weights)))
            ax.set_yticklabels([rf"$\hat C_{{{n[1]},{n.split('_')[1]}}}$" for n in weights], fontsize=5.5)
            ax.figure.colorbar(image, ax=ax, fraction=0.05, pad=0.02, label="weight")
            ax.set(title=r"Fuzzy weights $\hat C_1$ (top), $\hat C_2$ (bottom)")
            ax.grid(False)
        elif "e1" in inner:
            for i, (n, label) in enumerate((("e1", "e1 (along)"), ("e2", "e2 (across)"))):
                _line(ax, t, 100 * inner[n], color=PALETTE[i], label=label)
            ax.set(title="Tracking errors in the robot's frame", ylabel="[cm]")
            _legend(ax)
        elif "e_v" in inner:
            # The PID's own e_v and e_psi are in the Arduino's units (counts per 5 ms,
            # degrees): the same errors from the states, in SI-derived units.
            e_v = 100 * (result.reference("v") - result.states[:, 5])
            e_psi = np.degrees(np.angle(np.exp(1j * (result.reference("psi") - result.states[:, 2]))))
            _line(ax, t, e_v, color=PALETTE[0], label="$v_r - v$ [cm/s]")
            _line(ax, t, e_psi, color=PALETTE[1], label=r"$\psi_r - \psi$ [deg]")
            _robust_ylim(ax, e_v, e_psi)
            ax.set(title="PID errors: speed and heading", ylabel="[cm/s], [deg]")
            _legend(ax)
        else:
            ax.set_visible(False)
        panels.append(ax)
    for a in panels:
        a.set_xlim(t[0], t[-1])
    for a in panels[-3:]:
        a.set_xlabel("time [s]")
    _mark_ours_only(fig, beside)
    return _finish(fig, path, title or _title(scenario, "3-DOF run"))


# ----------------------------------------------------------------------------- sweeps

#: The metrics of `twip.simulate` and of sweeps, as shown (here and by the CLI):
#: name: (label, scale from SI, unit).
METRIC_UNITS = {
    "mean_abs_pitch_error": ("mean |φ − φ_s|", math.degrees(1), "deg"),
    "mean_abs_speed_error": ("mean |θ̇ − θ̇_ref|", math.degrees(1), "deg/s"),
    "pitch_settling_time": ("pitch settling time (2 %)", 1.0, "s"),
    "speed_settling_time": ("speed settling time (2 %)", 1.0, "s"),
    "final_position_error": ("final position error (short of the reference)", 100.0, "cm"),
    "peak_abs_input": ("peak |u|", 1.0, "A"),
    "peak_current": ("peak current in one motor (after the driver)", 1.0, "A"),
    "peak_torque": ("peak torque at one wheel", 1.0, "N m"),
    "peak_command": ("peak current commanded of one motor", 1.0, "A"),
    "saturation_share": ("share of control periods beyond the driver", 100.0, "%"),
    "mean_abs_x_error": ("mean |x − x_r|", 100.0, "cm"),
    "mean_abs_y_error": ("mean |y − y_r|", 100.0, "cm"),
    "mean_abs_x_error_settled": ("mean |x − x_r| after the first lap", 100.0, "cm"),
    "mean_abs_y_error_settled": ("mean |y − y_r| after the first lap", 100.0, "cm"),
    "max_path_error_settled": ("max distance to the path after the first lap", 100.0, "cm"),
    "mean_abs_pitch": ("mean |φ|", math.degrees(1), "deg"),
    "peak_abs_torque": ("peak |wheel torque|", 1.0, "N m"),
    "settle": ("settled metrics from", 1.0, "s"),
    "t_end": ("end time", 1.0, "s"),
}


def metric_unit(name: str):
    """(label, scale from SI, unit) of a metric; an unknown one is shown as it is."""
    return METRIC_UNITS.get(name, (name, 1.0, ""))


#: Figure labels (matplotlib mathtext) of the metrics whose plain label has dots and
#: subscripts; the plain label is the terminal's.
_METRIC_TEX = {
    "mean_abs_pitch_error": r"mean $|\varphi - \varphi_s|$",
    "mean_abs_speed_error": r"mean $|\dot\theta - \dot\theta_\mathrm{ref}|$",
    "mean_abs_x_error": r"mean $|x - x_r|$",
    "mean_abs_y_error": r"mean $|y - y_r|$",
}


def size_label(name: str) -> str:
    """A signed metric's label as its size: "|final position error|"."""
    return f"|{metric_unit(name)[0].split(' (')[0]}|"


def _metric_label(name: str) -> str:
    return _METRIC_TEX.get(name, metric_unit(name)[0])


#: The SI unit behind each display unit of METRIC_UNITS.
_SI = {"deg": "rad", "deg/s": "rad/s", "cm": "m", "%": ""}


def si_unit(name: str) -> str:
    """The SI unit of a metric as `twip.simulate` and sweeps hold it ("" if none)."""
    unit = metric_unit(name)[2]
    return _SI.get(unit, unit)


#: The most bins a histogram or a fall map takes along an axis: more than a figure has
#: pixels (and 10**9 would take gigabytes).
MAX_BINS = 1000


def _check_bins(bins, pair: bool = False) -> None:
    """Refuses bins that are not an integer from 1 to MAX_BINS (with `pair`, or two of them)."""
    each = tuple(bins) if pair and isinstance(bins, (tuple, list)) and len(bins) == 2 else (bins,)
    if not all(isinstance(b, (int, np.integer)) and not isinstance(b, bool) and 1 <= b <= MAX_BINS for b in each):
        raise _core.InvalidParameterError(
            f"bins = {bins!r}: must be an integer from 1 to {MAX_BINS}" + (" or a pair (x, y) of them" if pair else ""))


@_styled
def sweep(result, metrics: Optional[Sequence[str]] = None, path=None, title=None, bins: int = 30,
          sizes: Sequence[str] = ()):
    """Histograms of a sweep's metrics over the samples that did not fall (fall rate and its
    95 % interval in the title). `result` is a SweepResult (or anything with `.metrics`,
    `.fall_rate`, `.fall_rate_interval()` and `.config["scenario"]`). The metrics named in
    `sizes` are drawn as their size |x| (a signed error either side of its goal)."""
    m = result.metrics
    if metrics is None:
        metrics = [k for k in ("mean_abs_pitch_error", "mean_abs_speed_error", "final_position_error",
                               "mean_abs_x_error_settled", "mean_abs_y_error_settled", "max_path_error_settled")
                   if k in m][:3]
    # A str would be iterated letter by letter; an unknown name is a KeyError mid-figure.
    if isinstance(metrics, str) or not metrics or not all(isinstance(k, str) and k in m for k in metrics):
        raise _core.InvalidParameterError(f"metrics = {metrics!r}: must be a list of one or more of {', '.join(m)}")
    _check_bins(bins)
    keep = np.asarray(m["valid"], bool) & ~np.asarray(m["fell"], bool)
    fig = _figure((3.6 * len(metrics), 2.9), path)
    gs = _grid(fig, 1, len(metrics), top=1.0, wspace=0.3)
    for i, name in enumerate(metrics):
        ax = _axes(fig, gs[0, i])
        _, scale, unit = metric_unit(name)
        label = _metric_label(name)
        values = np.asarray(m[name], float)[keep] * scale
        values = values[np.isfinite(values)]
        if name in sizes:
            values, label = np.abs(values), size_label(name)
        if len(values):
            ax.hist(values, bins=bins, color=PALETTE[i % len(PALETTE)], alpha=0.85, edgecolor="white", linewidth=0.4)
            for q, ls in zip(np.quantile(values, (0.05, 0.5, 0.95)), (":", "-", ":")):
                ax.axvline(q, color=REF, ls=ls, lw=0.9)
        else:
            ax.text(0.5, 0.5, "every sample fell", ha="center", va="center", transform=ax.transAxes)
        ax.set(xlabel=f"{label} [{unit}]" if unit else label, ylabel="samples" if i == 0 else None)
    lo, hi = result.fall_rate_interval()
    head = title or f"{result.config['scenario']}: {result.n} samples"
    sub = f"fall rate {result.fall_rate:.1%} (95 % CI {lo:.1%}–{hi:.1%}); lines: median and 5 / 95 % quantiles"
    return _finish(fig, path, f"{head}\n{sub}")


def perturbed_values(result, name: str) -> np.ndarray:
    """The per-sample values of a perturbed quantity of a SweepResult, named as in
    `perturb=` (a RobotParams field, 'slope', 'phi0', 'x0[0]', ...)."""
    return result.drawn(name)


def _state_name(result, name: str) -> str:
    """'x0[0]' as its entry's name ('phi0'), for the axis label and unit; others unchanged."""
    kind, at = result.perturbation_target(name)
    return result.state_names[at] if kind == "x0" else name


_ANGLES = {"slope", "phi0", "phi_dot0", "theta0", "theta_dot0", "psi0", "omega0"}


def _axis_label(name):
    return {"slope": "slope [deg]", "phi0": "initial pitch φ(0) [deg]", "phi_dot0": r"initial pitch rate $\dot\varphi(0)$ [deg/s]",
            "theta0": "θ(0) [deg]", "theta_dot0": r"$\dot\theta(0)$ [deg/s]"}.get(name, name)


@_styled
def fall_map(result, x: str, y: str, bins=(12, 12), ax=None, path=None, title=None, colorbar: bool = True):
    """Fall rate of a sweep binned over two perturbed quantities (angles in degrees): which
    combinations the controller does not survive. Empty bins are left white."""
    _check_bins(bins, pair=True)
    xs, ys = perturbed_values(result, x), perturbed_values(result, y)
    x, y = _state_name(result, x), _state_name(result, y)
    if x in _ANGLES:
        xs = np.degrees(xs)
    if y in _ANGLES:
        ys = np.degrees(ys)
    fell = np.asarray(result.metrics["fell"], float)
    count, xe, ye = np.histogram2d(xs, ys, bins=bins)
    falls, _, _ = np.histogram2d(xs, ys, bins=(xe, ye), weights=fell)
    with np.errstate(invalid="ignore", divide="ignore"):
        rate = np.where(count > 0, falls / np.maximum(count, 1), np.nan)
    own = ax is None
    if own:
        fig = _figure((5, 4), path)
        ax = _axes(fig, 1, 1, 1)
    mesh = ax.pcolormesh(xe, ye, rate.T, cmap="Reds", vmin=0, vmax=1, shading="flat")
    ax.grid(False)
    ax.set(xlabel=_axis_label(x), ylabel=_axis_label(y))
    ax.set_title(title or f"{result.config['scenario']}: fall rate {result.fall_rate:.1%} of {result.n}")
    if colorbar:
        ax.figure.colorbar(mesh, ax=ax, label="fall rate (share of the starts in a cell that fell)", fraction=0.05,
                           pad=0.02)
    if own:
        return _finish(ax.figure, path)
    return ax


@_styled
def fall_maps(results: Sequence, x: str, y: str, bins=(12, 12), path=None, title=None):
    """Side-by-side fall-rate maps of several sweeps over the same two quantities, one colour bar."""
    if not len(results):
        raise _core.InvalidParameterError(f"results = {results!r}: give one or more sweeps to map")
    _check_bins(bins, pair=True)
    k = len(results)
    fig = _figure((4.4 * k + 1.4, 4.0), path)
    gs = _grid(fig, 1, k, right=0.95, wspace=0.2)  # room for the colour bar and its label
    axes = []
    for i, r in enumerate(results):
        ax = _axes(fig, gs[0, i])
        fall_map(r, x, y, bins=bins, ax=ax, colorbar=False)
        if i:
            ax.set_ylabel("")
        axes.append(ax)
    fig.colorbar(axes[0].collections[0], ax=axes, label="fall rate (share of the starts in a cell that fell)",
                 fraction=0.03, pad=0.02)
    return _finish(fig, path, title)


# ----------------------------------------------------------------------------- comparisons


def _plain_log_axis(ax):
    """Log y axis with plain numbers (0.1, 1, 10, 20, 50) instead of powers of ten."""
    from matplotlib.ticker import FuncFormatter, LogLocator

    ax.set_yscale("log")
    ax.yaxis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
    ax.yaxis.set_minor_locator(LogLocator(base=10, subs=(3.0, 4.0, 6.0, 7.0, 8.0, 9.0)))
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.yaxis.set_minor_formatter(FuncFormatter(lambda v, _: ""))


def bars(groups: Sequence[str], series: Mapping[str, Sequence[float]], ax, ylabel="", thesis: Optional[Mapping] = None,
         log: bool = False, marks: Optional[Mapping[str, Sequence[str]]] = None, robot: Optional[Mapping] = None,
         robot_fell: Optional[Mapping[str, Sequence[bool]]] = None):
    """Grouped bars: one group per label in `groups`, one bar per entry of `series`.
    `thesis` maps a series name to per-group values drawn as black diamonds on that bar;
    `marks` to per-group text written above the bars (e.g. 'fell'); `robot` to per-group
    values with the thesis-like robot in the loop, drawn as rings (NaN: not run, or fell);
    `robot_fell` to whether that run fell, drawn as a cross beside the dot. With `log` the values
    are dots on a stem from the axis, not bars (a bar's length means nothing on a log axis),
    and the axis shows plain numbers."""
    n = len(series)
    width = 0.8 / max(n, 1)
    xs = np.arange(len(groups))
    values_all = np.concatenate([np.asarray(v, float) for v in series.values()] +
                                [np.asarray(v, float) for v in (thesis or {}).values()] +
                                [np.asarray(v, float) for v in (robot or {}).values()])
    values_all = values_all[np.isfinite(values_all) & (values_all > 0)]
    bottom = 10 ** math.floor(math.log10(values_all.min())) if (log and len(values_all)) else 0.0  # a log axis's floor
    labelled = robot_labelled = fell_labelled = False
    for i, (name, given) in enumerate(series.items()):
        pos = xs - 0.4 + width * (i + 0.5)
        values = np.asarray(given, float)
        colour = PALETTE[i % len(PALETTE)]
        if log:
            ax.vlines(pos, bottom, values, color=colour, lw=1.0, alpha=0.6)
            ax.plot(pos, values, "o", color=colour, ms=5, label=name)
        else:
            ax.bar(pos, values, width * 0.92, color=colour, label=name)
        # The rings and crosses to the right of our dot, the thesis's diamond to its left: none hides another.
        beside = 0.35 * width
        if robot and name in robot:
            rv = np.asarray(robot[name], float)
            ok = np.isfinite(rv)
            if ok.any():
                ax.plot(pos[ok] + beside, rv[ok], "o", mfc="white", mec=colour, mew=1.4, ms=7,
                        label=None if robot_labelled else "thesis-like robot (rings)")
                robot_labelled = True
        if robot_fell and name in robot_fell:
            down = np.asarray(robot_fell[name], bool)
            if down.any():
                ax.plot(pos[down] + beside, values[down], "x", color=colour, mew=1.6, ms=7,
                        label=None if fell_labelled else "thesis-like robot fell (no ring)")
                fell_labelled = True
        if thesis and name in thesis:
            tv = np.asarray(thesis[name], float)
            ok = np.isfinite(tv)
            if ok.any():
                ax.plot(pos[ok] - beside, tv[ok], "D", color=REF, ms=6, mec="white", mew=0.8, label=None if labelled else "thesis")
                labelled = True
        if marks and name in marks:
            for p, v, txt in zip(pos, values, marks[name]):
                if txt:
                    ax.text(p, v, txt, ha="center", va="bottom", fontsize=6.5, rotation=90)
    ax.set_xticks(xs)
    ax.set_xticklabels(groups, rotation=0)
    ax.set_ylabel(ylabel)
    if log:
        _plain_log_axis(ax)
        ax.set_ylim(bottom=bottom)
    ax.grid(axis="x", visible=False)
    return ax


def _realism_value(row: Mapping, key: str, outcome: str) -> float:
    """A comparison row's number with the thesis-like robot, NaN (not drawn) when that run did
    not complete: a run that fell has no result to compare."""
    if key not in row or row.get(outcome, "completed") != "completed":
        return np.nan
    return row[key]


def _realism_fell(row: Mapping, outcome: str) -> bool:
    """Whether a comparison row's run with the thesis-like robot ran and did not complete."""
    return row.get(outcome, "completed") != "completed"


_CONTROLLER_NAMES = {"lqr": "LQR", "fuzzy": "fuzzy adaptive", "fuzzy-fixed": "fuzzy, adaptation off",
                     "fuzzy+ki": "fuzzy + ki"}


@_styled
def table_5_1(rows, thesis: Optional[Mapping] = None, path=None, title=None, thesis_on: str = "nominal"):
    """Table 5.1 analogue from `twip.scenarios.fuzzy.compare_table()` rows: mean |pitch error|
    and |wheel-speed error| per controller (bars) and plant (groups, a row's "case"), flat and
    slope. `thesis` maps (surface, controller) to the thesis's (pitch, speed), drawn on the
    group `thesis_on`."""
    fig = _figure((11, 6.4), path)
    gs = _grid(fig, 2, 2, top=0.75, bottom=0.95, hspace=0.5, wspace=0.2)
    controllers = list(dict.fromkeys(r["controller"] for r in rows))
    for i, surface in enumerate(dict.fromkeys(r["surface"] for r in rows)):
        sel = [r for r in rows if r["surface"] == surface]
        plants = list(dict.fromkeys(r["case"] for r in sel))
        given = {(r["case"], r["controller"]): r for r in sel}
        # a controller a group did not run draws nothing there
        cell = {(p, c): given.get((p, c), {"outcome": "completed", "pitch_error_deg": np.nan, "speed_error_deg_s": np.nan})
                for p in plants for c in controllers}
        for j, (key, ylabel, what) in enumerate((("pitch_error_deg", r"mean $|\varphi - \varphi_s|$ [deg]", "pitch"),
                                                 ("speed_error_deg_s", r"mean $|\dot\theta - \dot\theta_\mathrm{ref}|$ [deg/s]", "wheel-speed"))):
            ax = _axes(fig, gs[i, j])
            series = {_CONTROLLER_NAMES.get(c, c): [cell[(p, c)][key] for p in plants] for c in controllers}
            marks = {_CONTROLLER_NAMES.get(c, c): ["" if cell[(p, c)]["outcome"] == "completed" else cell[(p, c)]["outcome"]
                                                   for p in plants] for c in controllers}
            fell = {_CONTROLLER_NAMES.get(c, c): [_realism_fell(cell[(p, c)], "outcome_realism") for p in plants]
                    for c in controllers}
            th = None
            if thesis:
                th = {_CONTROLLER_NAMES.get(c, c): [thesis[(surface, c)][j] if p == thesis_on and (surface, c) in thesis
                                                    else np.nan for p in plants] for c in controllers}
            robot = {_CONTROLLER_NAMES.get(c, c): [_realism_value(cell[(p, c)], key + "_realism", "outcome_realism")
                                                   for p in plants] for c in controllers}
            bars(plants, series, ax, ylabel=ylabel, thesis=th, log=True, marks=marks, robot=robot, robot_fell=fell)
            ax.tick_params(axis="x", labelsize=8)  # six groups' names side by side
            ax.set_title(f"{surface}: mean {what} error")
    handles, labels = fig.axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=len(labels), frameon=False)
    return _finish(fig, path, title or "Table 5.1 analogue: the same go-and-back run for each controller; the controller's "
                   "model is the nominal robot,\nthe plant changes (thesis: black diamonds; rings: the thesis-like robot in the loop; "
                   "log scale)")


@_styled
def table_5_2(rows, thesis: Optional[Mapping] = None, path=None, title=None):
    """Table 5.2 analogue from `twip.scenarios.tracking.compare()` rows: mean |x − x_r| and
    |y − y_r| per tracker (bars) and plant (groups); `thesis` {"pid": (x, y), "smc": (x, y)}
    [m] drawn as horizontal lines (PID: the thesis's experiment; sliding mode: the thesis does not
    say whether simulation or experiment)."""
    fig = _figure((11, 4.3), path)
    gs = _grid(fig, 1, 2, top=0.75, bottom=1.0, wspace=0.2)
    plants = list(dict.fromkeys(r["plant"] for r in rows))
    trackers = list(dict.fromkeys(r["controller"] for r in rows))
    cell = {(r["plant"], r["controller"]): r for r in rows}
    for j, axis in enumerate(("x", "y")):
        ax = _axes(fig, gs[0, j])
        series = {t: [100 * cell[(p, t)][axis] for p in plants] for t in trackers}
        marks = {t: ["" if cell[(p, t)]["outcome"] == "completed" else cell[(p, t)]["outcome"] for p in plants]
                 for t in trackers}
        fell = {t: [_realism_fell(cell[(p, t)], "realism_outcome") for p in plants] for t in trackers}
        robot = {t: [100 * _realism_value(cell[(p, t)], f"{axis}_realism", "realism_outcome") for p in plants]
                 for t in trackers}
        bars(plants, series, ax, ylabel=rf"mean $|{axis} - {axis}_r|$ [cm]", log=True, marks=marks, robot=robot,
             robot_fell=fell)
        for k, (key, label) in enumerate((("pid", "thesis: PID (experiment)"),
                                             ("smc", "thesis: sliding mode (sim. or exp.: not stated)"))):
            if thesis and key in thesis:
                ax.axhline(100 * thesis[key][j], color=PALETTE[0 if key == "pid" else 2], ls="--", lw=1.3, label=label)
        ax.set_title(f"mean {axis} error over the whole run")
    handles, labels = fig.axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 4), frameon=False)
    return _finish(fig, path, title or "Table 5.2 analogue: each tracker on its circle; the controllers keep the nominal "
                   "model, the plant's masses, inertias,\nlengths and frictions change by ±20 % (rings: the thesis-like robot in "
                   "the loop, none where it fell; log scale)")
