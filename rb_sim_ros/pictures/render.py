# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""An animation of a recording (``replay --render run.mcap out.gif|out.mp4``).

Every body is drawn with its colliders from the recording's config (a body without any as
its inertia box: the uniform box with the same mass and principal moments, along its
principal axes), at the recorded poses, in an orthographic view (``iso``, ``top`` or
``side``), with a ground grid and the sim time. Frames come at the recording's publish rate,
or at ``fps`` (each shows the last publish at or before its time); a GIF takes every k-th of
them, so that each is shown a whole number of centiseconds, at least 20 ms (what viewers play
as written), and it plays in real time; it is written a frame at a time (memory: one frame,
whatever the length). The camera frames the whole run (its bodies and the static colliders
near them), or follows one body. Faces are shaded by a fixed light and drawn far to near.

GIF needs only Pillow (which matplotlib brings); MP4 needs imageio and imageio-ffmpeg, whose
wheel carries its own ffmpeg (no system ffmpeg). Everything is computed from the recording:
no ROS graph, no re-simulation.
"""

from __future__ import annotations

from array import array
import contextlib
from dataclasses import dataclass
import math
import os
import sys

import numpy as np

from rb_sim_ros.contact import shapes
from rb_sim_ros.core.so3 import rotation9_from_unit_quaternion as rotation_from_quaternion
from rb_sim_ros.pictures.plots import lifetimes, rotation_matrices
from rb_sim_ros.sim.simulation import Delete, Spawn

VIEWS = ('iso', 'top', 'side')
# Body colours (RGB), in the order of the run's bodies; static bodies are grey.
PALETTE = ((31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40), (148, 103, 189),
           (140, 86, 75), (227, 119, 194), (188, 189, 34), (23, 190, 207))
STATIC_COLOUR = (150, 150, 150)
BACKGROUND = (255, 255, 255)
GRID_COLOUR = (215, 215, 215)
LIGHT = np.array([0.4, -0.5, 0.77])
# The points of each rim a cylinder's outline is drawn through.
RIM_POINTS = 32
MAX_FPS = 1000.0
MAX_FRAMES = 100_000
# A GIF's delays are whole centiseconds, and viewers play a delay under 20 ms slower: every
# frame of a GIF is shown a whole number of centiseconds, at least MIN_GIF_DELAY_CS.
MAX_GIF_DELAY_CS = 65535
MIN_GIF_DELAY_CS = 2
# A GIF is written a frame at a time (memory: one frame, whatever the number); its frames hold
# at most this many pixels in all (a bound on the file and on the time to draw it, about
# 110,000 frames of 640x480); more frames are thinned out to fit.
MAX_GIF_PIXELS = 1 << 35
GIF_COLOURS = 64
# Bodies further from the origin than this (m), and parts larger, are not drawn.
MAX_EXTENT = 1e6


def camera(view: str) -> np.ndarray:
    """Rows: the screen's right, up, and the direction toward the viewer (world frame)."""
    if view == 'top':
        return np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    if view == 'side':  # looking along +y: x to the right, z up
        return np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
    if view != 'iso':
        raise ValueError(f'view must be one of {list(VIEWS)}, got {view!r}')
    toward = np.array([1.0, -1.0, 0.8])
    toward /= np.linalg.norm(toward)
    right = np.cross([0.0, 0.0, 1.0], toward)
    right /= np.linalg.norm(right)
    return np.array([right, np.cross(toward, right), toward])


@dataclass
class Part:
    """One drawable piece of a body, in its body frame, a drawing primitive of its collider
    (contact.shapes.pieces): 'sphere' (radius), 'box' (half extents), 'capsule' or
    'cylinder' (radius, half length along z), 'mesh' (vertices, triangles), at ``position``
    turned by ``rotation``."""

    primitive: str
    size: tuple
    position: np.ndarray
    rotation: np.ndarray


def inertia_box(spec) -> Part | None:
    """The uniform box with the body's mass and principal moments, on its principal axes;
    None if it is not finite or larger than MAX_EXTENT."""
    inertia = np.array(spec.inertia, dtype=float)
    inertia = np.diag(inertia) if inertia.size == 3 else inertia.reshape(3, 3)
    moments, axes = np.linalg.eigh(inertia)
    if np.linalg.det(axes) < 0:
        axes[:, 2] = -axes[:, 2]
    a, b, c = moments
    m = spec.mass
    with np.errstate(all='ignore'):
        half = tuple(0.5 * math.sqrt(max(6.0 * (s - 2.0 * own) / m, 1e-12))
                     for own, s in ((a, a + b + c), (b, a + b + c), (c, a + b + c)))
    if not all(math.isfinite(h) and h <= MAX_EXTENT for h in half):
        return None
    return Part('box', half, np.zeros(3), axes)


def parts_of(spec) -> list[Part]:
    """What to draw of a body: its colliders (planes are the ground grid's), or its inertia
    box when it has none. A collider further from the body's centre than MAX_EXTENT, or
    larger, or not finite, is left out (its pixels would overflow), in one line."""
    out, far = [], 0
    for c in spec.colliders:
        for primitive, size, at, r in shapes.pieces(c):
            if primitive == 'plane':  # (drawn as the ground grid)
                continue
            part = Part(primitive, tuple(size), np.array(at, dtype=float), np.array(r))
            if _drawable_part(part):
                out.append(part)
            else:
                far += 1
    if far:
        _note(f'body {spec.name!r}: {far} of its colliders are larger than {MAX_EXTENT:g} m, '
              'further from its centre, or not finite: not drawn')
    if not spec.colliders:
        box = inertia_box(spec)
        if box is None:
            _note(f'body {spec.name!r}: its inertia box (mass {spec.mass:.3g} kg) is larger '
                  f'than {MAX_EXTENT:g} m or not finite: not drawn')
        else:
            out.append(box)
    return out


def _drawable_part(part: Part) -> bool:
    size = part.size[0] if part.primitive == 'mesh' else part.size
    values = np.concatenate([np.asarray(size, dtype=float).ravel(), part.position,
                             part.rotation.ravel()])
    return bool(np.all(np.isfinite(values)) and np.all(np.abs(values) <= MAX_EXTENT)
                and _extent(part) <= MAX_EXTENT)


def _placed(spec) -> bool:
    """Whether a static body's pose can be drawn: finite, within MAX_EXTENT of the origin."""
    values = np.array([*spec.initial_position, *spec.initial_orientation_xyzw], dtype=float)
    return bool(np.all(np.isfinite(values)) and np.all(np.abs(values[:3]) <= MAX_EXTENT)
                and np.linalg.norm(values[3:]) > 0.0)


def ground_height(specs) -> float:
    """z of the first horizontal static plane (the ground), else 0."""
    for spec in specs:
        if not spec.static:
            continue
        for c in spec.colliders:
            for primitive, _, at, rot in shapes.pieces(c):
                if primitive != 'plane':
                    continue
                r = np.array(rotation_from_quaternion(spec.initial_orientation_xyzw))
                r = r.reshape(3, 3)
                normal = r @ rot[:, 2]  # the plane's, solid below it
                if normal[2] > 0.999:
                    point = np.array(spec.initial_position) + r @ at
                    if abs(point[2]) <= MAX_EXTENT:  # (else the grid is drawn at 0)
                        return float(point[2])
    return 0.0


def _extent(p: Part) -> float:
    """How far a part reaches from its own centre (m)."""
    if p.primitive == 'capsule':
        return p.size[0] + p.size[1]
    if p.primitive == 'cylinder':
        return math.hypot(p.size[0], p.size[1])
    if p.primitive == 'mesh':
        return float(np.sqrt((np.asarray(p.size[0]) ** 2).sum(axis=1)).max())
    return max(p.size) * (math.sqrt(3.0) if p.primitive == 'box' else 1.0)


def _reach(parts) -> float:
    """How far a body's parts reach from its centre (m), whatever its turn."""
    return max((float(np.linalg.norm(p.position)) + _extent(p) for p in parts), default=0.1)


def _hull_2d(points: np.ndarray) -> np.ndarray:
    """The convex hull of 2-D points, in order round it (Andrew's monotone chain)."""
    ordered = sorted(map(tuple, np.asarray(points, dtype=float)))

    def half(seq):
        out: list = []
        for p in seq:
            while len(out) >= 2 and ((out[-1][0] - out[-2][0]) * (p[1] - out[-2][1])
                                     - (out[-1][1] - out[-2][1]) * (p[0] - out[-2][0])) <= 0:
                out.pop()
            out.append(p)
        return out[:-1]
    return np.array(half(ordered) + half(ordered[::-1]))


def _part_points(part: Part, x, r) -> tuple[np.ndarray, float]:
    """(points, padding): the part at pose (x, r) lies within ``padding`` of the points'
    convex hull (a box's 8 corners, a capsule's two ends, a sphere's centre, a mesh's
    vertices)."""
    rot = r @ part.rotation
    at = x + r @ part.position
    if part.primitive == 'sphere':
        return at[None, :], part.size[0]
    if part.primitive == 'mesh':
        return at + np.asarray(part.size[0]) @ rot.T, 0.0
    if part.primitive in ('capsule', 'cylinder'):  # a cylinder lies within its capsule
        radius, half = part.size
        return np.array([at - rot[:, 2] * half, at + rot[:, 2] * half]), radius
    signs = np.array([[a, b, c] for a in (-1, 1) for b in (-1, 1) for c in (-1, 1)], float)
    return at + (signs * np.array(part.size)) @ rot.T, 0.0


class Timeline:
    """The recorded poses of every body at every publish, and when each body existed."""

    def __init__(self, rec) -> None:
        self.lives = {name: [(start, spec, parts_of(spec)) for start, spec in lives]
                      for name, lives in lifetimes(rec).items()}
        self.specs = {name: lives[-1][1] for name, lives in self.lives.items()}
        self.order = [b.name for b in rec.config.bodies]
        self.initial = set(self.order)
        dt = rec.config.dt
        self.deleted_at: dict[str, list] = {}
        self.spawned_at: dict[str, list] = {}
        for step, e, _ in rec.inputs:
            if isinstance(e, Spawn):
                if e.spec.name not in self.order:
                    self.order.append(e.spec.name)
                self.spawned_at.setdefault(e.spec.name, []).append(step * dt)
            elif isinstance(e, Delete):
                self.deleted_at.setdefault(e.body, []).append(step * dt)
        # One pass over the outputs (which may be read from the file as they are iterated),
        # keeping 8 floats a pose, not the messages.
        poses: dict[str, array] = {}
        for step, body, kind, _t, msg, log_time in rec.outputs:
            if kind == 'pose':
                p, o = msg.pose.position, msg.pose.orientation
                row = poses.get(body)
                if row is None:
                    row = poses[body] = array('d')
                row.extend((log_time * 1e-9, p.x, p.y, p.z, o.x, o.y, o.z, o.w))
        self.tracks = {}
        for name, row in poses.items():
            a = np.frombuffer(row, dtype=float).reshape(-1, 8)
            ok = np.all(np.isfinite(a), axis=1) & np.all(np.abs(a[:, 1:4]) <= MAX_EXTENT, axis=1)
            if not ok.all():
                _note(f'body {name!r}: {int((~ok).sum())} of its {len(ok)} recorded positions '
                      f'are not finite or further than {MAX_EXTENT:g} m: not drawn there')
            a = a[ok]
            self.tracks[name] = (a[:, 0], a[:, 1:4], a[:, 4:8])  # t, position, quaternion
        self.times = np.unique(np.concatenate(
            [np.frombuffer(row, dtype=float)[::8] for row in poses.values()] or [np.zeros(0)]))
        del poses
        self.parts = {name: [p for _, _, parts in lives for p in parts]  # (for the extent)
                      for name, lives in self.lives.items()}
        for name, lives in self.lives.items():
            if any(spec.static and not _placed(spec) for _, spec, _ in lives):
                _note(f'body {name!r}: its position is further than {MAX_EXTENT:g} m or its '
                      'pose not finite: not drawn')
        self.ground = ground_height(self.specs.values())
        self.colour = {}
        for i, name in enumerate(self.order):
            self.colour[name] = STATIC_COLOUR if self.specs[name].static else \
                PALETTE[i % len(PALETTE)]

    def _present(self, name: str, t: float) -> bool:
        """Whether a static body is in the run at ``t``: from the start (a body of the
        config) or its spawn, until it is deleted."""
        present = name in self.initial
        changes = sorted([(s, True) for s in self.spawned_at.get(name, [])]
                         + [(d, False) for d in self.deleted_at.get(name, [])])
        for when, appears in changes:
            if when <= t + 1e-12:
                present = appears
        return present

    def life(self, name: str, t: float):
        """(BodySpec, parts) of ``name`` at ``t``: of its last spawn strictly before t (a
        spawn follows the publish of its step), else the config's."""
        lives = self.lives[name]
        k = max(0, int(np.searchsorted([start for start, _, _ in lives], t, side='left')) - 1)
        return lives[k][1], lives[k][2]

    def state(self, name: str, t: float):
        """(position, rotation) of ``name`` at the last publish at or before ``t``, or None
        if it was not there then (not yet spawned, deleted, or not finite)."""
        spec = self.life(name, t)[0]
        if spec.static:
            if not self._present(name, t) or not _placed(spec):
                return None
            return (np.array(spec.initial_position), np.array(
                rotation_from_quaternion(spec.initial_orientation_xyzw)).reshape(3, 3))
        track = self.tracks.get(name)
        if track is None:
            return None
        times, x, q = track
        k = int(np.searchsorted(times, t + 1e-12, side='right')) - 1
        if k < 0:
            return None
        # Gone if a publish of the run came after its last one and before t.
        later = self.times[(self.times > times[k] + 1e-12) & (self.times <= t + 1e-12)]
        if len(later):
            return None
        with np.errstate(all='ignore'):
            return x[k], rotation_matrices(q[k:k + 1])[0]


def _frame_times(timeline: Timeline, fps: float | None) -> np.ndarray:
    times = timeline.times
    if not len(times):
        return times
    if fps is None:
        return times
    if not (isinstance(fps, (int, float)) and math.isfinite(fps) and 0 < fps <= MAX_FPS):
        raise ValueError(f'fps must be a number in (0, {MAX_FPS:g}], got {fps!r}')
    count = int(math.floor((times[-1] - times[0]) * fps + 1e-9)) + 1
    if count > MAX_FRAMES:
        raise ValueError(f'{count} frames at {fps:g} fps: at most {MAX_FRAMES} (lower --fps)')
    return times[0] + np.arange(count) / fps


class Renderer:
    """Frames of a recording: ``frame(t)`` is a PIL image of the run at sim time t."""

    def __init__(self, rec, view: str = 'iso', size=(640, 480), follow: str | None = None
                 ) -> None:
        self.timeline = tl = Timeline(rec)
        self.cam = camera(view)
        self.view = view
        self.width, self.height = (int(size[0]), int(size[1]))
        if not (64 <= self.width <= 4096 and 64 <= self.height <= 4096):
            raise ValueError(f'size must be from 64 to 4096 pixels a side, got {size!r}')
        if follow is not None and follow not in tl.tracks:
            raise ValueError(f'--follow {follow!r}: no recorded moving body of that name (have '
                             f'{sorted(tl.tracks)})')
        self.follow = follow
        self.centre, self.scale, self.grid_box = self._framing()

    def _framing(self):
        """(centre (m, screen), scale (pixels a metre), grid's world box): the view holds
        every moving body's recorded positions with its own reach, and the static colliders
        near them (within half their span beyond it: a long wall or a large slab is cut
        there, a far one is left out); with no moving body, the static ones."""
        tl = self.timeline
        moving_uv, moving_xyz = [], []  # (lo, hi) boxes, screen and world
        for name, (_times, x, _r) in tl.tracks.items():
            if not len(x):
                continue
            reach = _reach(tl.parts[name])
            uv = x @ self.cam[:2].T
            moving_uv.append((uv.min(axis=0) - reach, uv.max(axis=0) + reach))
            moving_xyz.append((x.min(axis=0) - reach, x.max(axis=0) + reach))
        static_uv, static_xyz = [], []
        for name, lives in tl.lives.items():
            for _, spec, parts in lives:
                if not (spec.static and parts and _placed(spec)):
                    continue
                x = np.array(spec.initial_position, dtype=float)
                r = np.array(rotation_from_quaternion(spec.initial_orientation_xyzw)
                             ).reshape(3, 3)
                for part in parts:
                    points, pad = _part_points(part, x, r)
                    uv = points @ self.cam[:2].T
                    static_uv.append((uv.min(axis=0) - pad, uv.max(axis=0) + pad))
                    static_xyz.append((points.min(axis=0) - pad, points.max(axis=0) + pad))
        if moving_uv:
            uv_box = _near(_union(moving_uv), static_uv)
            xyz_box = _near(_union(moving_xyz), static_xyz)
        elif static_uv:
            uv_box, xyz_box = _union(static_uv), _union(static_xyz)
        else:
            uv_box = (np.full(2, -0.1), np.full(2, 0.1))
            xyz_box = (np.full(3, -0.1), np.full(3, 0.1))
        lo, hi = uv_box
        if self.follow is not None:
            half = max(4.0 * _reach(tl.parts[self.follow]), 1.0)
            lo, hi = -np.array([half, half]), np.array([half, half])
        span = np.maximum(hi - lo, 1e-6)
        scale = 0.9 * min(self.width / span[0], self.height / span[1])
        return 0.5 * (lo + hi), scale, xyz_box

    def _to_pixels(self, uv: np.ndarray, centre) -> np.ndarray:
        """Screen coordinates (m) to pixels (x right, y down)."""
        px = (uv[..., 0] - centre[0]) * self.scale + 0.5 * self.width
        py = 0.5 * self.height - (uv[..., 1] - centre[1]) * self.scale
        return np.stack([px, py], axis=-1)

    def frame(self, t: float):
        from PIL import Image, ImageDraw
        tl = self.timeline
        image = Image.new('RGB', (self.width, self.height), BACKGROUND)
        draw = ImageDraw.Draw(image)
        centre = self.centre
        if self.follow is not None:
            state = tl.state(self.follow, t)
            if state is not None:
                centre = state[0] @ self.cam[:2].T
        self._grid(draw, centre)
        drawn = []  # (depth, kind, pixels, colour)
        for name in tl.order:
            state = tl.state(name, t)
            if state is None:
                continue
            x, r = state
            for part in tl.life(name, t)[1]:
                drawn.extend(self._part(part, x, r, tl.colour[name], centre))
        drawn.sort(key=lambda s: s[0])
        for _, kind, pixels, colour in drawn:
            if kind == 'circle':
                (cx, cy), radius = pixels
                draw.ellipse([cx - radius, cy - radius, cx + radius, cy + radius], fill=colour,
                             outline=tuple(int(0.6 * c) for c in colour))
            else:
                draw.polygon([tuple(p) for p in pixels], fill=colour,
                             outline=tuple(int(0.6 * c) for c in colour))
        draw.text((8, 6), f't = {t:.3f} s   ({self.view} view)', fill=(0, 0, 0))
        return image

    def _grid(self, draw, centre) -> None:
        lo, hi = self.grid_box
        span = max(hi[0] - lo[0], hi[1] - lo[1], 1e-3)
        step = 10.0 ** math.floor(math.log10(span / 4.0))
        z = self.timeline.ground
        x0, x1 = math.floor(lo[0] / step) * step, math.ceil(hi[0] / step) * step
        y0, y1 = math.floor(lo[1] / step) * step, math.ceil(hi[1] / step) * step
        lines = []
        for x in np.arange(x0, x1 + 0.5 * step, step):
            lines.append(((x, y0, z), (x, y1, z)))
        for y in np.arange(y0, y1 + 0.5 * step, step):
            lines.append(((x0, y, z), (x1, y, z)))
        for a, b in lines[:400]:
            ends = self._to_pixels(np.array([a, b]) @ self.cam[:2].T, centre)
            draw.line([tuple(ends[0]), tuple(ends[1])], fill=GRID_COLOUR, width=1)

    def _part(self, part: Part, x, r, colour, centre):
        rot = r @ part.rotation
        at = x + r @ part.position
        depth_axis = self.cam[2]
        if part.primitive == 'sphere':
            uv = self._to_pixels(at @ self.cam[:2].T, centre)
            return [(float(at @ depth_axis), 'circle', (uv, part.size[0] * self.scale),
                     _shade(colour, 1.0))]
        if part.primitive == 'capsule':
            radius, half = part.size
            ends = np.array([at + rot @ (0.0, 0.0, -half), at + rot @ (0.0, 0.0, half)])
            uv = self._to_pixels(ends @ self.cam[:2].T, centre)
            d = uv[1] - uv[0]
            n = np.array([-d[1], d[0]]) / max(float(np.hypot(*d)), 1e-9) * radius * self.scale
            depth = float(at @ depth_axis)
            col = _shade(colour, 1.0)
            return [(depth, 'circle', (uv[0], radius * self.scale), col),
                    (depth, 'circle', (uv[1], radius * self.scale), col),
                    (depth + 1e-9, 'polygon', np.array([uv[0] + n, uv[1] + n, uv[1] - n,
                                                        uv[0] - n]), col)]
        if part.primitive == 'cylinder':  # its outline: the hull of its two rims, seen
            radius, half = part.size
            turn = np.linspace(0.0, 2.0 * math.pi, RIM_POINTS, endpoint=False)
            rim = np.stack([radius * np.cos(turn), radius * np.sin(turn),
                            np.zeros(RIM_POINTS)], axis=1)
            points = np.concatenate([rim + (0.0, 0.0, -half), rim + (0.0, 0.0, half)])
            uv = self._to_pixels((at + points @ rot.T) @ self.cam[:2].T, centre)
            light = LIGHT / np.linalg.norm(LIGHT)
            return [(float(at @ depth_axis), 'polygon', _hull_2d(uv),
                     _shade(colour, 0.6 + 0.4 * abs(float(rot[:, 2] @ light))))]
        if part.primitive == 'mesh':  # its triangles that face the camera, each lit
            return self._mesh(part, at, rot, colour, centre)
        hx, hy, hz = part.size
        out = []
        light = LIGHT / np.linalg.norm(LIGHT)
        for axis in range(3):
            for sign in (-1.0, 1.0):
                normal = rot[:, axis] * sign
                if normal @ depth_axis <= 0.0:
                    continue  # faces away
                a, b = [k for k in range(3) if k != axis]
                half = np.array([hx, hy, hz])
                corners = []
                for sa, sb in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                    local = np.zeros(3)
                    local[axis] = sign * half[axis]
                    local[a], local[b] = sa * half[a], sb * half[b]
                    corners.append(at + rot @ local)
                corners = np.array(corners)
                uv = self._to_pixels(corners @ self.cam[:2].T, centre)
                out.append((float(corners.mean(axis=0) @ depth_axis), 'polygon', uv,
                            _shade(colour, 0.55 + 0.45 * max(0.0, float(normal @ light)))))
        return out

    def _mesh(self, part: Part, at, rot, colour, centre):
        vertices, triangles = part.size
        world = at + np.asarray(vertices) @ rot.T
        light = LIGHT / np.linalg.norm(LIGHT)
        out = []
        for tri in np.asarray(triangles):
            corners = world[tri]
            normal = np.cross(corners[1] - corners[0], corners[2] - corners[0])
            length = float(np.linalg.norm(normal))
            if length == 0.0 or normal @ self.cam[2] <= 0.0:
                continue  # no area, or faces away
            uv = self._to_pixels(corners @ self.cam[:2].T, centre)
            out.append((float(corners.mean(axis=0) @ self.cam[2]), 'polygon', uv,
                        _shade(colour, 0.55 + 0.45 * max(0.0, float(normal @ light) / length))))
        return out


def _union(boxes):
    """The (lo, hi) box around (lo, hi) boxes."""
    return (np.min([lo for lo, _ in boxes], axis=0), np.max([hi for _, hi in boxes], axis=0))


def _near(box, others):
    """``box`` grown to hold what of ``others`` lies within half its span (at least 0.5 m)
    beyond it."""
    lo, hi = box
    margin = max(0.5 * float(np.max(hi - lo)), 0.5)
    reach_lo, reach_hi = lo - margin, hi + margin
    for other_lo, other_hi in others:
        if np.all(other_hi >= reach_lo) and np.all(other_lo <= reach_hi):
            lo = np.minimum(lo, np.maximum(other_lo, reach_lo))
            hi = np.maximum(hi, np.minimum(other_hi, reach_hi))
    return lo, hi


def _note(message: str) -> None:
    """One line on stderr: what the animation leaves out, or how it had to thin its frames."""
    print(f'render: {message}', file=sys.stderr)


def gif_frames(times: np.ndarray, width: int, height: int):
    """The frames of a GIF of ``times`` (s, increasing): (frame times, delays in ms). Every
    k-th time, with k the least that makes every delay at least MIN_GIF_DELAY_CS centiseconds
    and the frames' pixels at most MAX_GIF_PIXELS; each delay is whole centiseconds, rounded
    so that a frame starts at its time's whole centisecond, and the last is shown one stride:
    the GIF plays in real time, its length the run's within one frame."""
    times = np.asarray(times, dtype=float)
    if len(times) < 2:
        return times, [10 * MIN_GIF_DELAY_CS] * len(times)
    span = float(times[-1] - times[0])
    period = span / (len(times) - 1)  # (the times are the publishes or an fps's: even)
    stride = max(1, math.ceil(MIN_GIF_DELAY_CS / 100.0 / period - 1e-9)) if period > 0 else 1
    most = max(1, MAX_GIF_PIXELS // (width * height))
    if math.ceil(len(times) / stride) > most:
        thin = math.ceil(len(times) / most)
        _note(f'{len(times)} frames of {width}x{height} are more than a GIF can hold here '
              f'({MAX_GIF_PIXELS >> 20} Mpixels): every {thin}th drawn (lower --fps or --size, '
              f'or write an .mp4)')
        stride = max(stride, thin)
    chosen = times[::stride]
    starts = [int(round(100.0 * (t - times[0]))) for t in chosen]
    starts.append(starts[-1] + max(MIN_GIF_DELAY_CS, int(round(100.0 * stride * period))))
    delays, at = [], starts[0]
    for k in range(len(chosen)):
        end = max(starts[k + 1], at + MIN_GIF_DELAY_CS)
        # A GIF holds a delay in 16 bits of centiseconds: longer frames are shown for 655.35 s.
        delays.append(10 * min(end - at, MAX_GIF_DELAY_CS))
        at = end
    return chosen, delays


def _shade(colour, k: float):
    return tuple(int(min(255, c * k)) for c in colour)


def render(rec, out_path: str, view: str = 'iso', fps: float | None = None,
           follow: str | None = None, size=(640, 480), progress=None) -> int:
    """Write the animation of ``rec`` to ``out_path`` (.gif, or .mp4 with imageio and
    imageio-ffmpeg); the number of frames. ValueError, one line, for a bad option."""
    lower = out_path.lower()
    if not lower.endswith(('.gif', '.mp4')):
        raise ValueError(f'{out_path}: the output must end in .gif or .mp4')
    renderer = Renderer(rec, view, size, follow)
    times = _frame_times(renderer.timeline, fps)
    if not len(times):
        raise ValueError(f'{rec.path}: no recorded poses to draw')
    rate = fps if fps is not None else (
        1.0 / (rec.config.dt * rec.config.steps_per_publish))
    if lower.endswith('.gif') and fps is not None and rate > 100.0 / MIN_GIF_DELAY_CS:
        _note(f'{rate:g} frames a second: a GIF shows each frame at least '
              f'{10 * MIN_GIF_DELAY_CS} ms, so it gets at most {100 / MIN_GIF_DELAY_CS:g} (an '
              '.mp4 gets them all)')
    if lower.endswith('.mp4'):
        try:
            import imageio.v2 as imageio
            import imageio_ffmpeg  # noqa: F401 - the ffmpeg binary's wheel
        except ImportError:
            raise ValueError('an .mp4 needs imageio and imageio-ffmpeg (pip install imageio '
                             'imageio-ffmpeg; no system ffmpeg needed); a .gif needs neither'
                             ) from None
        writer = imageio.get_writer(out_path, fps=rate, codec='libx264', quality=7,
                                    macro_block_size=8)
        try:
            for k, t in enumerate(times):
                writer.append_data(np.asarray(_drawn(renderer, t)))
                if progress is not None:
                    progress(k + 1, len(times))
        finally:
            writer.close()
        return len(times)
    times, delays = gif_frames(times, renderer.width, renderer.height)
    _write_gif(out_path, renderer, times, delays, progress)
    return len(times)


class GifWriter:
    """A looping GIF written frame by frame, so that only the last frame is held: the header
    and global colour table from the first frame (Pillow's ``GifImagePlugin.getheader``),
    then each frame as the rectangle that changed since the one before, with its own colour
    table and its delay in a Graphic Control Extension (``GifImagePlugin.getdata``), then the
    trailer. Frames are RGB images of one size; delays in ms, whole centiseconds."""

    def __init__(self, file) -> None:
        self.file = file
        self.previous = None
        self.count = 0

    def add(self, image, delay_ms: int) -> None:
        from PIL import GifImagePlugin, ImageChops
        if self.previous is None:
            part = image.quantize(colors=GIF_COLOURS)
            header, _ = GifImagePlugin.getheader(part, None, {'loop': 0, 'duration': delay_ms})
            self._write(header)
            self._write(GifImagePlugin.getdata(part, (0, 0), duration=delay_ms))
        else:
            box = ImageChops.difference(image, self.previous).getbbox() or (0, 0, 1, 1)
            part = image.crop(box).quantize(colors=GIF_COLOURS)
            self._write(GifImagePlugin.getdata(part, box[:2], duration=delay_ms,
                                               include_color_table=True))
        self.previous = image
        self.count += 1

    def close(self) -> None:
        self.file.write(b';')  # the trailer

    def _write(self, blocks) -> None:
        for block in blocks:
            self.file.write(bytes(block))


def _write_gif(out_path: str, renderer: Renderer, times, delays, progress) -> None:
    """Draw and write the GIF's frames one at a time, into a file beside ``out_path`` that
    replaces it once the last is written (a frame that cannot be drawn leaves no half
    GIF)."""
    import tempfile
    folder = os.path.dirname(os.path.abspath(out_path))
    try:
        fd, part_path = tempfile.mkstemp(prefix='.render-', suffix='.gif', dir=folder)
    except OSError as e:
        raise ValueError(f'{out_path}: cannot write there ({e.strerror})') from None
    try:
        with os.fdopen(fd, 'wb') as f:
            writer = GifWriter(f)
            for k, (t, delay) in enumerate(zip(times, delays)):
                writer.add(_drawn(renderer, t), delay)
                if progress is not None:
                    progress(k + 1, len(times))
            writer.close()
            # (mkstemp makes it 0600: the GIF gets the mode any new file of the user gets)
            umask = os.umask(0o022)
            os.umask(umask)
            os.chmod(f.fileno(), 0o666 & ~umask)
        os.replace(part_path, out_path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.remove(part_path)
        raise


def _drawn(renderer: Renderer, t: float):
    """The frame at ``t``; ValueError, one line, if it cannot be drawn."""
    try:
        with np.errstate(all='ignore'):
            return renderer.frame(float(t))
    except (OverflowError, FloatingPointError, ValueError) as e:
        raise ValueError(f'the frame at t = {t:.3f} s cannot be drawn: {e}') from None
