"""Animated GIFs of a run, drawn with Pillow (no matplotlib needed).

    import twip, twip.animate
    sc = twip.scenarios.get("slope-lqr")
    twip.animate.gif(sc.run(), "slope-lqr.gif", scenario=sc)

2-DOF runs are drawn from the side, on the slope, with the camera following the robot
(wheel with a spoke, body at its true pitch, the reference position as a red marker, a
strip at the bottom with the whole trip). 3-DOF runs are drawn from above (the reference
path, the robot's trail and its wheels and body at its heading) beside a side view of
the pitch. Frames are taken every 1/fps seconds of the simulation times `speed`
(default: real time, faster for long runs so that the GIF lasts at most `max_seconds`).
"""
from __future__ import annotations

import math
from typing import Optional

import numpy as np

from twip import _core, budget, checks

BACKGROUND = (250, 250, 247)
GROUND = (222, 205, 170)
GROUND_LINE = (120, 100, 70)
WHEEL = (60, 60, 66)
RIM = (150, 150, 160)
BODY = (31, 95, 168)
BODY_EDGE = (15, 50, 95)
COM = (240, 200, 60)
REFERENCE = (192, 57, 43)
TRAIL = (31, 95, 168)
PATH = (150, 150, 150)
TEXT = (30, 30, 30)
MUTED = (110, 110, 110)
PANEL = (241, 241, 235)

SUPERSAMPLE = 2
COLOURS = 32


def _pil():
    try:
        from PIL import Image, ImageDraw, ImageFont
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("twip.animate needs Pillow: pip install 'twip[plot]'") from e
    return Image, ImageDraw, ImageFont


def _font(size):
    _, _, ImageFont = _pil()
    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1: a fixed bitmap font
        return ImageFont.load_default()


def _speed(duration, speed, max_seconds):
    if speed is not None:
        if not (speed > 0 and math.isfinite(speed)):
            raise ValueError(f"speed = {speed}: must be a positive number")
        return float(speed)
    if duration <= max_seconds:
        return 1.0
    for nice in (2, 4, 5, 8, 10, 15, 20, 25, 40, 50, 100):
        if duration / nice <= max_seconds:
            return float(nice)
    return duration / max_seconds


def _frame_indices(t, fps, speed):
    times = np.arange(t[0], t[-1] + 1e-9, speed / fps)
    idx = np.clip(np.searchsorted(t, times, side="right") - 1, 0, len(t) - 1)
    return times, idx


class _Canvas:
    """World (metres, y up) to supersampled pixels."""

    def __init__(self, draw, scale, origin_px, centre_m):
        self.draw, self.scale = draw, scale
        self.ox, self.oy = origin_px
        self.cx, self.cy = centre_m

    def px(self, x, y):
        return (self.ox + (x - self.cx) * self.scale, self.oy - (y - self.cy) * self.scale)

    def polygon(self, points, fill, outline=None, width=1):
        self.draw.polygon([self.px(*p) for p in points], fill=fill, outline=outline,
                          width=width * SUPERSAMPLE if outline else 0)

    def line(self, points, fill, width=1):
        self.draw.line([self.px(*p) for p in points], fill=fill, width=max(1, int(width * SUPERSAMPLE)), joint="curve")

    def circle(self, centre, radius_m, fill=None, outline=None, width=1, min_px=0.0):
        x, y = self.px(*centre)
        r = max(radius_m * self.scale, min_px * SUPERSAMPLE)
        self.draw.ellipse([x - r, y - r, x + r, y + r], fill=fill, outline=outline,
                          width=max(1, int(width * SUPERSAMPLE)) if outline else 0)


def _rect(centre, along, length, width):
    """Corners of a rectangle centred at `centre`, `length` along unit vector `along`."""
    ax, ay = along
    nx, ny = -ay, ax
    cx, cy = centre
    hl, hw = length / 2, width / 2
    return [(cx + ax * hl + nx * hw, cy + ay * hl + ny * hw), (cx - ax * hl + nx * hw, cy - ay * hl + ny * hw),
            (cx - ax * hl - nx * hw, cy - ay * hl - ny * hw), (cx + ax * hl - nx * hw, cy + ay * hl - ny * hw)]


def _robot_side(cv, axle, phi, wheel_angle, r, l, body_colour=BODY):
    """Wheel at `axle` turned by `wheel_angle`, body leaning `phi` from the vertical."""
    up = (math.sin(phi), math.cos(phi))
    height = max(2.0 * l + r, 3.0 * r)
    width = 1.1 * r
    centre = (axle[0] + up[0] * height / 2, axle[1] + up[1] * height / 2)
    cv.polygon(_rect(centre, up, height, width), fill=body_colour, outline=BODY_EDGE, width=1)
    cv.circle((axle[0] + up[0] * l, axle[1] + up[1] * l), 0.18 * r, fill=COM, outline=BODY_EDGE, width=1)
    cv.circle(axle, r, fill=WHEEL, outline=RIM, width=1.5)
    for k in range(3):  # three spokes, turned with the wheel (clockwise when rolling forward)
        a = -wheel_angle + k * 2 * math.pi / 3
        cv.line([axle, (axle[0] + 0.85 * r * math.sin(a), axle[1] + 0.85 * r * math.cos(a))], fill=RIM, width=1.5)
    cv.circle(axle, 0.12 * r, fill=RIM)


def _finish_frame(image):
    return image.reduce(SUPERSAMPLE) if SUPERSAMPLE > 1 else image


def _text(draw, xy, text, font, fill=TEXT, anchor="la"):
    draw.text((xy[0] * SUPERSAMPLE, xy[1] * SUPERSAMPLE), text, font=font, fill=fill, anchor=anchor)


def _save(frames, path, fps):
    Image, ImageDraw, _ = _pil()
    # One palette for the whole GIF (no flicker): from a few frames plus large swatches of
    # the drawing colours, so that small red markers keep their own entry.
    sample = frames[:: max(1, len(frames) // 6)][:6]
    w, h = frames[0].size
    keys = (BACKGROUND, GROUND, GROUND_LINE, WHEEL, RIM, BODY, BODY_EDGE, COM, REFERENCE, PATH, TEXT, MUTED, PANEL)
    sheet = Image.new("RGB", (w, h * (len(sample) + 1)), BACKGROUND)
    for i, f in enumerate(sample):
        sheet.paste(f, (0, h * i))
    swatch = ImageDraw.Draw(sheet)
    step = w / len(keys)
    for k, colour in enumerate(keys):
        swatch.rectangle([k * step, h * len(sample), (k + 1) * step, h * (len(sample) + 1)], fill=colour)
    palette = sheet.quantize(colors=COLOURS, method=Image.Quantize.MEDIANCUT)
    quantised = [f.quantize(palette=palette, dither=Image.Dither.NONE) for f in frames]
    quantised[0].save(path, save_all=True, append_images=quantised[1:], duration=int(round(1000 / fps)), loop=0,
                      optimize=False, disposal=1)


#: Frames per second a GIF can show (its frame delay is in hundredths of a second).
MAX_FPS = 100.0
#: ... and the fewest: the delay is 16 bits of hundredths, at most 655.35 s.
MIN_FPS = 1 / 655.35


def check_options(path, fps: float = 20.0, speed: Optional[float] = None, size=None,
                  max_seconds: float = 15.0) -> None:
    """Refuses, before any run or drawing, a GIF path whose folder is missing or whose
    name does not end in .gif, and an fps, speed, size or max_seconds that is not a
    positive number (fps at most MAX_FPS)."""
    from twip.plot import check_folder

    if not str(path).lower().endswith(".gif"):
        raise _core.InvalidParameterError(f"animation path {str(path)!r}: must end in .gif (an animated GIF is written)")
    check_folder(path)
    if isinstance(fps, bool) or not isinstance(fps, (int, float)) or not (MIN_FPS <= fps <= MAX_FPS):
        raise _core.InvalidParameterError(f"fps = {fps!r}: must be a number in [{MIN_FPS:.4g}, {MAX_FPS:g}] (frames "
                                          "per second; a GIF holds a frame at most 655.35 s)")
    if speed is not None and (isinstance(speed, bool) or not isinstance(speed, (int, float))
                              or not (speed > 0 and math.isfinite(speed))):
        raise _core.InvalidParameterError(f"speed = {speed!r}: must be a positive number")
    if size is not None and not (isinstance(size, (tuple, list)) and len(size) == 2
                                 and all(isinstance(v, int) and not isinstance(v, bool) and 16 <= v <= 4096 for v in size)):
        raise _core.InvalidParameterError(f"size = {size!r}: must be (width, height) in pixels, each 16..4096")
    checks.real("max_seconds", max_seconds, above=0)


def _check_frames(count: int, size) -> None:
    """The frames (drawn supersampled, kept at size) against the memory budget."""
    w, h = size
    need = count * w * h * 3 * 2 + w * h * 3 * SUPERSAMPLE**2
    budget.check(f"animation: {count:,} frames of {w}x{h} pixels", need, "lower fps or raise speed=")


def gif(result, path, scenario=None, params=None, slope: Optional[float] = None, fps: float = 20.0,
        speed: Optional[float] = None, max_seconds: float = 15.0, size=None, title: Optional[str] = None) -> dict:
    """Writes an animated GIF of `result` to `path`; returns {"frames", "seconds", "speed"}.

    `scenario` (or `params` and `slope`) gives the robot's dimensions and the ground; the
    defaults are RobotParams.balanbot() on the flat. `size` is (width, height) in pixels."""
    if scenario is not None:
        params = scenario.model.params
        slope = getattr(scenario.model, "slope", 0.0)
        title = title or scenario.name
    if params is None:
        from twip import RobotParams

        params = RobotParams.balanbot()
    if slope is not None:
        checks.real("slope", slope)
    check_options(path, fps, speed, size, max_seconds)
    t = np.asarray(result.t)
    duration = float(t[-1] - t[0])
    speed = _speed(duration, speed, max_seconds)
    planar = result.states.shape[1] == 7
    size = size or ((640, 400) if planar else (560, 340))
    frames = duration / speed * fps
    if not math.isfinite(frames):  # a speed so small (5e-324) that the count overflows
        raise _core.InvalidParameterError(f"speed = {speed!r}: too slow, the frames of {duration:g} s of "
                                          "run are beyond counting; raise speed")
    _check_frames(int(frames) + 1, size)
    times, idx = _frame_indices(t, fps, speed)
    if planar:
        frames = _planar_frames(result, params, times, idx, speed, size, title)
    else:
        frames = _slope_frames(result, params, slope or 0.0, times, idx, speed, size, title)
    _save(frames, path, fps)
    return {"frames": len(frames), "seconds": len(frames) / fps, "speed": speed}


# ----------------------------------------------------------------------------- 2-DOF


def _slope_frames(result, params, alpha, times, idx, speed, size, title):
    Image, ImageDraw, _ = _pil()
    W, H = size
    r, l = params.wheel_radius, params.com_height
    phi, _, theta, theta_dot = result.states.T
    s_robot = theta * r
    s_ref = result.reference("theta") * r if "theta" in result.reference_names else None
    w_ref = result.reference("theta_dot") if "theta_dot" in result.reference_names else None
    phi_s = result.internals.get("phi_s")
    g = (math.cos(alpha), math.sin(alpha))
    n = (-math.sin(alpha), math.cos(alpha))
    height = max(2.0 * l + r, 3.0 * r)
    scale = 0.36 * H / height * SUPERSAMPLE  # the robot fills about a third of the height
    font, small = _font(13 * SUPERSAMPLE), _font(11 * SUPERSAMPLE)
    lo = min(s_robot.min(), s_ref.min() if s_ref is not None else 0.0)
    hi = max(s_robot.max(), s_ref.max() if s_ref is not None else 0.0)
    hi = hi if hi - lo > 1e-6 else lo + 1.0
    view = W * SUPERSAMPLE / scale  # metres across
    frames = []
    for tf, i in zip(times, idx):
        img = Image.new("RGB", (W * SUPERSAMPLE, H * SUPERSAMPLE), BACKGROUND)
        draw = ImageDraw.Draw(img)
        s = s_robot[i]
        contact = (s * g[0], s * g[1])
        axle = (contact[0] + r * n[0], contact[1] + r * n[1])
        cv = _Canvas(draw, scale, (W * SUPERSAMPLE / 2, H * SUPERSAMPLE * 0.55), (axle[0], axle[1] + 0.4 * height))
        # ground: a band below the slope line across the view
        a, b = s - view, s + view
        line = [(a * g[0], a * g[1]), (b * g[0], b * g[1])]
        depth = 2 * view
        cv.polygon(line + [(b * g[0] - depth * n[0], b * g[1] - depth * n[1]),
                           (a * g[0] - depth * n[0], a * g[1] - depth * n[1])], fill=GROUND)
        cv.line(line, fill=GROUND_LINE, width=2)
        step = 0.1 if view < 3 else 0.5
        for k in range(int(math.floor(a / step)), int(math.ceil(b / step)) + 1):
            d = k * step
            p = (d * g[0], d * g[1])
            major = k % 5 == 0
            size_m = (0.5 if major else 0.25) * r
            cv.line([p, (p[0] - size_m * n[0], p[1] - size_m * n[1])], fill=GROUND_LINE, width=1.5 if major else 1)
            if major or step >= 0.5:
                x, y = cv.px(p[0] - 0.9 * r * n[0], p[1] - 0.9 * r * n[1])
                draw.text((x, y), f"{d:.1f} m", font=small, fill=GROUND_LINE, anchor="mt")
        if s_ref is not None:  # the reference position: a red marker on the ground
            p = (s_ref[i] * g[0], s_ref[i] * g[1])
            tri = [(p[0], p[1]), (p[0] - 0.35 * r * g[0] + 0.6 * r * n[0], p[1] - 0.35 * r * g[1] + 0.6 * r * n[1]),
                   (p[0] + 0.35 * r * g[0] + 0.6 * r * n[0], p[1] + 0.35 * r * g[1] + 0.6 * r * n[1])]
            cv.polygon(tri, fill=REFERENCE)
        _robot_side(cv, axle, phi[i], theta[i], r, l)
        # text
        _text(draw, (10, 8), f"t = {tf:5.2f} s" + (f"   (x{speed:g} speed)" if speed != 1 else ""), font)
        line2 = f"pitch {math.degrees(phi[i]):6.2f}°"
        if phi_s is not None:
            line2 += f"   target {math.degrees(phi_s[i]):5.2f}°"
        _text(draw, (10, 27), line2, small)
        line3 = f"wheel {math.degrees(theta_dot[i]):6.1f}°/s"
        if w_ref is not None:
            line3 += f"   ref {math.degrees(w_ref[i]):6.1f}°/s"
        _text(draw, (10, 43), line3, small)
        _text(draw, (10, 59), f"position {s:5.3f} m" + (f"   ref {s_ref[i]:5.3f} m" if s_ref is not None else ""), small)
        if title:
            _text(draw, (W - 10, 8), title, font, anchor="ra")
            if alpha:
                _text(draw, (W - 10, 27), f"slope {math.degrees(alpha):.0f}°", small, fill=MUTED, anchor="ra")
        if result.fell and tf >= result.t_end:
            _text(draw, (W / 2, H * 0.2), "FELL", _font(28 * SUPERSAMPLE), fill=REFERENCE, anchor="mm")
        # the whole trip: a strip along the bottom
        draw.rectangle([0, (H - 30) * SUPERSAMPLE, W * SUPERSAMPLE, H * SUPERSAMPLE], fill=BACKGROUND)
        draw.line([(0, (H - 30) * SUPERSAMPLE), (W * SUPERSAMPLE, (H - 30) * SUPERSAMPLE)], fill=RIM, width=SUPERSAMPLE)
        y0 = (H - 14) * SUPERSAMPLE
        x_lo, x_hi = 62 * SUPERSAMPLE, (W - 62) * SUPERSAMPLE
        to_x = lambda v: x_lo + (v - lo) / (hi - lo) * (x_hi - x_lo)
        draw.line([(x_lo, y0), (x_hi, y0)], fill=MUTED, width=SUPERSAMPLE)
        _text(draw, (56, H - 14), f"{lo:.2f} m", small, fill=MUTED, anchor="rm")
        _text(draw, (W - 56, H - 14), f"{hi:.2f} m", small, fill=MUTED, anchor="lm")
        if s_ref is not None:
            xr = to_x(s_ref[i])
            draw.polygon([(xr, y0 - 2), (xr - 5 * SUPERSAMPLE, y0 - 11 * SUPERSAMPLE),
                          (xr + 5 * SUPERSAMPLE, y0 - 11 * SUPERSAMPLE)], fill=REFERENCE)
        xs = to_x(s)
        rr = 4.5 * SUPERSAMPLE
        draw.ellipse([xs - rr, y0 - rr, xs + rr, y0 + rr], fill=BODY)
        frames.append(_finish_frame(img))
    return frames


# ----------------------------------------------------------------------------- 3-DOF


def _planar_frames(result, params, times, idx, speed, size, title):
    Image, ImageDraw, _ = _pil()
    W, H = size
    r, l, b = params.wheel_radius, params.com_height, params.half_track
    x, y, psi, phi, _, v, omega = result.states.T
    xr, yr = result.reference("x"), result.reference("y")
    v_ref, w_ref = result.reference("v"), result.reference("omega")
    t = np.asarray(result.t)
    travelled = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])
    font, small = _font(13 * SUPERSAMPLE), _font(11 * SUPERSAMPLE)
    # top view: a fixed camera on everything the run visits
    side_w = int(W * 0.34)
    main = W - side_w
    xs_all, ys_all = np.concatenate([x, xr]), np.concatenate([y, yr])
    span = max(xs_all.max() - xs_all.min(), ys_all.max() - ys_all.min(), 4 * b) + 4 * b
    scale_top = (min(main, H) - 20) * SUPERSAMPLE / span
    centre_top = ((xs_all.max() + xs_all.min()) / 2, (ys_all.max() + ys_all.min()) / 2)
    # the reference path, thinned
    keep = np.unique(np.linspace(0, len(xr) - 1, min(len(xr), 400)).astype(int))
    ref_path = list(zip(xr[keep], yr[keep]))
    height = max(2.0 * l + r, 3.0 * r)
    scale_side = min(0.36 * H / height, 0.7 * side_w / (2 * r)) * SUPERSAMPLE
    # the static layer: the reference path; the robot's trail is added to it as it grows
    base = Image.new("RGB", (W * SUPERSAMPLE, H * SUPERSAMPLE), BACKGROUND)
    base_draw = ImageDraw.Draw(base)
    top_base = _Canvas(base_draw, scale_top, (main * SUPERSAMPLE / 2, (H / 2 + 8) * SUPERSAMPLE), centre_top)
    for k in range(0, len(ref_path) - 1, 2):  # dashed
        top_base.line(ref_path[k:k + 2], fill=PATH, width=1.5)
    drawn = 0
    frames = []
    for tf, i in zip(times, idx):
        if i > drawn:
            seg = np.unique(np.linspace(drawn, i, min(i - drawn + 1, 60)).astype(int))
            top_base.line(list(zip(x[seg], y[seg])), fill=TRAIL, width=2)
            drawn = i
        img = base.copy()
        draw = ImageDraw.Draw(img)
        top = _Canvas(draw, scale_top, (main * SUPERSAMPLE / 2, (H / 2 + 8) * SUPERSAMPLE), centre_top)
        top.circle((xr[i], yr[i]), 0.0, fill=REFERENCE, min_px=5)
        heading = (math.cos(psi[i]), math.sin(psi[i]))
        left = (-heading[1], heading[0])
        centre = (x[i], y[i])
        top.polygon(_rect(centre, heading, 1.6 * r, 2 * b * 0.8), fill=BODY, outline=BODY_EDGE, width=1)
        for side in (1, -1):
            wc = (centre[0] + side * b * left[0], centre[1] + side * b * left[1])
            top.polygon(_rect(wc, heading, 2 * r, 0.3 * r), fill=WHEEL)
        nose = (centre[0] + 1.4 * r * heading[0], centre[1] + 1.4 * r * heading[1])
        top.line([centre, nose], fill=COM, width=2)
        # side panel: the pitch, magnified, on its own layer (clipped to the panel)
        panel = Image.new("RGB", (side_w * SUPERSAMPLE, H * SUPERSAMPLE), PANEL)
        pdraw = ImageDraw.Draw(panel)
        ground_y = 0.56 * H * SUPERSAMPLE
        side = _Canvas(pdraw, scale_side, (side_w * SUPERSAMPLE / 2, ground_y), (0.0, 0.0))
        pdraw.rectangle([0, ground_y, side_w * SUPERSAMPLE, ground_y + 0.06 * H * SUPERSAMPLE], fill=GROUND)
        pdraw.line([(0, ground_y), (side_w * SUPERSAMPLE, ground_y)], fill=GROUND_LINE, width=2 * SUPERSAMPLE)
        side.line([(0, r), (0, r + 1.1 * height)], fill=MUTED, width=1)  # the vertical, for reference
        _robot_side(side, (0.0, r), phi[i], travelled[i] / r, r, l)
        _text(pdraw, (side_w / 2, 8), "side view (pitch)", small, fill=MUTED, anchor="ma")
        hud = [f"t = {tf:5.1f} s" + (f"  (x{speed:g})" if speed != 1 else ""),
               f"pitch {math.degrees(phi[i]):5.2f}°",
               f"speed {100 * v[i]:5.1f} cm/s (ref {100 * v_ref[i]:4.1f})",
               f"yaw rate {math.degrees(omega[i]):5.1f}°/s (ref {math.degrees(w_ref[i]):4.1f})",
               f"to reference {100 * math.hypot(x[i] - xr[i], y[i] - yr[i]):5.1f} cm"]
        for k, text in enumerate(hud):
            _text(pdraw, (10, H - 96 + 17 * k), text, font if k == 0 else small)
        img.paste(panel, (main * SUPERSAMPLE, 0))
        if title:
            _text(draw, (10, 8), title, font)
        _text(draw, (10, 26), "top view: reference (grey), path (blue), reference point (red)", small, fill=MUTED)
        if result.fell and tf >= result.t_end:
            _text(draw, (main / 2, H / 2), "FELL", _font(28 * SUPERSAMPLE), fill=REFERENCE, anchor="mm")
        frames.append(_finish_frame(img))
    return frames
