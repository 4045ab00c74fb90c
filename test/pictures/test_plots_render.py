# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
# pypi-only: mcap
"""replay --plot and --render, checked as a person would: the plotted quantities against
mechanics, the animation's pixels against the recorded poses (a ball's image goes down and up
as its recorded height does, a static wall stays put), and the files read back."""

import math
from pathlib import Path

import numpy as np
import pytest

from oracles.node_recording import record_offline
from rb_sim_ros.contact.collision_shapes import Box, Cylinder, Hull, Plane, Sphere
from rb_sim_ros.core.rigid_body import Wrench
from rb_sim_ros.offline import replay
from rb_sim_ros.pictures import plots, render
from rb_sim_ros.sim.scene import load_scene
from rb_sim_ros.sim.simulation import (BodySpec, Config, ContactSettings, Delete, SetPose,
                                       SetWrench, Spawn)

ROOT = Path(__file__).resolve().parents[2]
FIXTURE = ROOT / 'test' / 'fixtures' / 'regression.mcap'
COLLISIONS = ROOT / 'test' / 'fixtures' / 'collision_demo.mcap'


@pytest.fixture(scope='module')
def demo(tmp_path_factory):
    """The collision demo, 1.5 s: the ball falls from 2 m, bounces and falls again."""
    scene = load_scene(str(ROOT / 'scenes' / 'collisions.yaml'))
    config = Config(dt=1e-3, steps_per_publish=10, gravity=scene.gravity, bodies=scene.bodies,
                    contact=scene.contact)
    return record_offline(tmp_path_factory.mktemp('demo') / 'demo.mcap', config, 150)


def _mask(image, colour):
    return np.all(np.asarray(image.convert('RGB')) == colour, axis=2)


def test_the_ball_image_goes_down_and_up_as_its_recorded_height(demo):
    r = render.Renderer(demo, 'side', (480, 360))
    colour = r.timeline.colour['ball']
    rows, heights, seen = [], [], []
    for t in r.timeline.times:
        mask = _mask(r.frame(float(t)), colour)
        seen.append(mask.sum())
        rows.append(np.nonzero(mask)[0].mean() if mask.any() else np.nan)
        heights.append(r.timeline.state('ball', float(t))[0][2])
    seen, rows, heights = np.array(seen), np.array(rows), np.array(heights)
    whole = seen >= 0.9 * seen.max()  # not hidden behind another body
    assert whole.sum() > 100
    # Image rows grow downwards: the centroid's row is height, mapped by the view's scale.
    fit = np.polyfit(heights[whole], rows[whole], 1)
    assert fit[0] == pytest.approx(-r.scale, rel=0.02)
    assert np.abs(np.polyval(fit, heights[whole]) - rows[whole]).max() < 1.0  # pixels
    # and the recorded height does go down, up and down again (a bounce), so does the image.
    lowest = int(np.argmin(heights[:100]))
    assert 0 < lowest < 99 and heights[lowest] < 0.2 < heights[lowest + 25]
    assert rows[lowest] > rows[0] and rows[lowest] > rows[lowest + 25]


def test_a_static_wall_stays_put_in_every_view(demo):
    for view in render.VIEWS:
        r = render.Renderer(demo, view, (320, 240))
        boxes, counts = [], []
        for t in r.timeline.times[::5]:
            rgb = np.asarray(r.frame(float(t)).convert('RGB')).astype(int)
            grey = (rgb[..., 0] == rgb[..., 1]) & (rgb[..., 1] == rgb[..., 2]) & \
                (rgb[..., 0] > 60) & (rgb[..., 0] < 200)
            grey[:20] = False  # the time's text
            ys, xs = np.nonzero(grey)
            counts.append(len(xs))
            boxes.append((xs.min(), xs.max(), ys.min(), ys.max()) if len(xs) else None)
        full = [b for b, c in zip(boxes, counts) if c >= 0.98 * max(counts)]
        assert len(full) > 5 and all(b == full[0] for b in full), view


def _coloured(image):
    """Where the moving bodies are drawn: pixels of a colour (static bodies, the grid, the
    background and the time's text are grey)."""
    rgb = np.asarray(image.convert('RGB')).astype(int)
    mask = np.ptp(rgb, axis=2) > 20
    mask[:20] = False  # the time's text
    return mask


def _spans(mask):
    """(width, height) fractions of the image that ``mask``'s pixels span."""
    rows, cols = np.nonzero(mask)
    return np.ptp(cols) / mask.shape[1], np.ptp(rows) / mask.shape[0]


@pytest.mark.parametrize('view', render.VIEWS)
def test_the_collision_scene_fills_the_picture(view):
    """The view holds the moving bodies with their own colliders and the static wall beside
    them, not the wall's reach around every body: in every frame the moving bodies span more
    than 25% of the width or height, and over the run more than half (issue 28: they were
    drawn in a tenth of the image). (The run's own content sets the first: since impacts pass
    down the stack as pairwise collisions, the top view at 0.8 s spans 29.7%.)"""
    rec = replay.load(str(COLLISIONS))
    r = render.Renderer(rec, view, (320, 240))
    union = np.zeros((240, 320), bool)
    for t in r.timeline.times[::10]:
        mask = _coloured(r.frame(float(t)))
        assert max(_spans(mask)) > 0.25, (view, t, _spans(mask))
        union |= mask
    assert max(_spans(union)) > 0.5, (view, _spans(union))


@pytest.mark.parametrize('far', [
    BodySpec('far', static=True, initial_position=(1e8, 0.0, 0.0), colliders=(Box((1,) * 3),)),
    BodySpec('far', static=True, initial_position=(0.0, 3.0, 0.0),
             colliders=(Box((1e8, 1.0, 1.0)),)),
    BodySpec('far', static=True, initial_position=(0.0, 3.0, 0.0),
             colliders=(Sphere(0.5, position=(0.0, 0.0, 1e8)),)),
    BodySpec('far', 1.0, (0.1,) * 3, initial_position=(0.0, 0.6, 1.0),
             colliders=(Sphere(0.1), Sphere(0.1, position=(1e8, 0.0, 0.0)))),
    BodySpec('far', static=True, initial_position=(0.0, 0.0, 0.0),
             colliders=(Plane(offset=-1e8),)),
    BodySpec('far', static=True, initial_position=(0.0, 80.0, 0.0), colliders=(Box((1,) * 3),)),
], ids=['static_far', 'collider_huge', 'collider_far', 'moving_collider_far', 'plane_far',
        'static_beyond'])
def test_huge_or_far_colliders_leave_the_view_to_the_bodies(tmp_path, far, capsys):
    """A static body 1e8 m away, a collider 1e8 m long or 1e8 m from its body's centre, a
    ground 1e8 m down (render.MAX_EXTENT, 1e6 m, applies to them as to the recorded
    positions), or a wall 80 m away: each is left out, in one line naming it when it cannot
    be drawn, and the ball still fills the view."""
    ball = BodySpec('ball', 1.0, (0.004,) * 3, initial_position=(0.0, 0.0, 1.0),
                    colliders=(Sphere(0.25),))
    rec = record_offline(tmp_path / 'r.mcap', Config(bodies=(ball, far)), 3)
    capsys.readouterr()
    # (4 publishes 10 ms apart: every other one, 20 ms a frame)
    assert render.render(rec, str(tmp_path / 'r.gif'), 'iso', size=(200, 200)) == 2
    err = capsys.readouterr().err
    assert 'Traceback' not in err
    assert all(line.startswith("render: body 'far'") for line in err.splitlines()), err
    r = render.Renderer(rec, 'iso', (200, 200))
    ball_pixels = _mask(r.frame(0.0), r.timeline.colour['ball'])
    assert max(_spans(ball_pixels)) > 0.3, _spans(ball_pixels)


def test_the_regression_fixture_moves_on_screen_as_recorded():
    rec = replay.load(str(FIXTURE))
    r = render.Renderer(rec, 'top', (400, 400))
    colour = np.array(r.timeline.colour['body'])
    xs, ys, px, py = [], [], [], []
    for t in r.timeline.times:
        rgb = np.asarray(r.frame(float(t)).convert('RGB')).astype(int)
        # Every shade of the body's colour: faces are shaded c * k.
        ratio = rgb / np.maximum(colour, 1)
        mask = (np.abs(ratio - ratio[..., :1]) < 0.03).all(axis=2) & (ratio[..., 0] > 0.3) & \
            (rgb.sum(axis=2) < 600)
        rows, cols = np.nonzero(mask)
        x, rot = r.timeline.state('body', float(t))
        xs.append(x[0])
        ys.append(x[1])
        px.append(cols.mean())
        py.append(rows.mean())
    # Top view: x right, y up; the box's image centre moves with its recorded position (the
    # box is symmetric: its centroid is its centre, whatever its turn).
    assert np.corrcoef(xs, px)[0, 1] > 0.99 and np.corrcoef(ys, py)[0, 1] < -0.99
    assert np.ptp(xs) > 0.02  # it does move (the teleport and the push)


def test_the_animation_files_read_back(demo, tmp_path):
    gif = tmp_path / 'demo.gif'
    assert render.render(demo, str(gif), 'iso', fps=25.0, size=(200, 150)) == 38  # 1.5 s
    from PIL import Image
    with Image.open(gif) as im:
        assert im.n_frames == 38 and im.size == (200, 150)
    pytest.importorskip('imageio_ffmpeg')
    import imageio.v2 as imageio
    mp4 = tmp_path / 'demo.mp4'
    n = render.render(demo, str(mp4), 'side', follow='ball', size=(200, 160))
    assert n == 151
    reader = imageio.get_reader(str(mp4))
    try:
        assert sum(1 for _ in reader) == 151
    finally:
        reader.close()


@pytest.mark.parametrize('kwargs, words', [
    ({'view': 'front'}, 'view must be one of'), ({'fps': 0.0}, 'fps must be'),
    ({'fps': float('nan')}, 'fps must be'), ({'follow': 'nobody'}, "--follow 'nobody'"),
    ({'size': (10, 10)}, 'size must be'), ({'out': 'x.avi'}, 'must end in .gif or .mp4'),
])
def test_bad_render_options_are_one_line(demo, tmp_path, kwargs, words):
    out = str(tmp_path / kwargs.pop('out', 'x.gif'))
    with pytest.raises(ValueError, match=words.replace('(', r'\(')):
        render.render(demo, out, **kwargs)


def test_plotted_quantities_are_mechanics(tmp_path):
    """Torque-free, a body keeps its kinetic energy and world-frame angular momentum; under a
    held force its position is F t^2 / 2m. The wrench is plotted as held, events where they
    took effect; the files are PNGs."""
    spec = BodySpec('b', 2.0, (0.1, 0.2, 0.3), initial_angular_velocity=(0.3, 1.0, -2.0))
    config = Config(dt=1e-3, steps_per_publish=10, bodies=(spec,))
    force = Wrench((4.0, 0.0, 0.0))
    rec = record_offline(tmp_path / 'run.mcap', config, 100, events={
        20: [SetWrench(force, 'b')], 60: [SetPose((0.0, 0.0, 1.0), (0, 0, 0, 1), 'b')]})
    s = plots.body_series(rec)['b']
    inertia = np.diag(spec.inertia)
    w0 = np.array(spec.initial_angular_velocity)
    assert s.energy[0] == pytest.approx(0.5 * w0 @ inertia @ w0, rel=1e-12)
    before = s.t < 0.59 + 1e-9  # the teleport turns the body: L = R I R^T w changes
    assert np.abs(s.momentum[before] - inertia @ w0).max() < 1e-5 * np.linalg.norm(
        inertia @ w0)
    assert np.abs(s.energy[:19] - s.energy[0]).max() < 1e-6 * s.energy[0]  # unforced
    # (an input of period p takes effect at its start: step 10 (p - 1), the publish before)
    t = s.t[19:60] - 0.19
    assert s.position[19:60, 0] == pytest.approx(0.5 * 2.0 * t * t, abs=1e-9)
    rpy = plots.roll_pitch_yaw(np.array([[0.0, 0.0, np.sin(0.5), np.cos(0.5)]]))
    assert rpy[0] == pytest.approx((0.0, 0.0, 1.0), abs=1e-15)  # 1 rad about z is yaw
    times, forces, _, _ = plots.wrench_steps(rec, 'b', s.t[-1])
    assert list(times) == pytest.approx([0.0, 0.19, 1.0]) and forces[1, 0] == 4.0
    marks = [(k, round(t, 6)) for t, k, _ in plots.events(rec)]
    assert marks == [('wrench', 0.19), ('teleport', 0.59)]
    files = plots.plot(rec, str(tmp_path / 'plots'))
    assert [Path(f).name for f in files] == ['b.png']
    assert Path(files[0]).read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'


def test_contact_counts_come_from_the_run(tmp_path):
    """A box resting on the ground touches it at its 4 corners; a ball dropped beside it adds
    none while in the air and one once it rests (restitution 0, no sleeping)."""
    ground = BodySpec('ground', static=True, colliders=(Plane(),))
    box = BodySpec('box', 1.0, (1 / 6,) * 3, initial_position=(0.0, 0.0, 0.25),
                   colliders=(Box((0.5, 0.5, 0.5)),))
    ball = BodySpec('ball', 1.0, (0.004,) * 3, initial_position=(2.0, 0.0, 1.0),
                    colliders=(Sphere(0.1),))
    config = Config(dt=1e-3, steps_per_publish=10, gravity=(0.0, 0.0, -9.81),
                    bodies=(ground, box, ball), contact=ContactSettings(sleep_time=0.0))
    rec = record_offline(tmp_path / 'c.mcap', config, 200)
    times, counts = plots.contact_counts(rec)
    assert list(times) == pytest.approx([0.01 * k for k in range(201)])
    assert counts[0] == 0  # before the first step: none yet
    assert list(counts[1:30]) == [4] * 29  # the ball (1 m up) in the air for 0.4 s
    assert list(counts[150:]) == [5] * 51  # at rest beside the box


def _main(*args):
    import contextlib
    import io
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = replay.main(['replay', *args])
        except SystemExit as e:
            code = e.code
    return code, out.getvalue(), err.getvalue()


def test_the_command_line(demo, tmp_path):
    code, out, err = _main('--plot', demo.path, '--out', str(tmp_path / 'p'), '--bodies',
                           'ball,crate')
    assert code == 0, err
    assert sorted(Path(line).name for line in out.split()) == ['ball.png', 'contacts.png',
                                                               'crate.png']
    code, out, err = _main('--render', demo.path, str(tmp_path / 'a.gif'), '--view', 'top',
                           '--fps', '10', '--size', '160x120')
    assert code == 0 and '16 frames written' in out and 'rendering frame: 16/16' in err
    for args, words in [(('--render', demo.path), '--render needs FILE and OUT'),
                        (('--plot', demo.path, '--view', 'top'), 'only for --render'),
                        (('--render', demo.path, 'a.gif', '--size', '12'), '--size must be'),
                        (('--plot', demo.path, '--bodies', 'nobody'), "['nobody']"),
                        (('--render', demo.path, 'x.gif', '--follow', 'ground'), 'ground')]:
        code, out, err = _main(*args)
        assert code == 2 and err.count('\n') == 1 and words in err, (args, err)


def test_a_name_spawned_again_is_plotted_and_drawn_as_the_body_it_names_then(tmp_path):
    """'b' lives twice: 1 kg at 1 m/s, then, deleted and spawned again, 100 kg at 1 m/s: its
    kinetic energy is 0.5 J, then 50 J; the animation draws each with its own shape."""
    first = BodySpec('b', 1.0, (0.1,) * 3, initial_linear_velocity=(1.0, 0.0, 0.0),
                     colliders=(Sphere(0.1),))
    second = BodySpec('b', 100.0, (10.0,) * 3, initial_position=(0.0, 2.0, 0.0),
                      initial_linear_velocity=(1.0, 0.0, 0.0),
                      colliders=(Box((0.4, 0.4, 0.4)),))
    anchor = BodySpec('anchor', initial_position=(0.0, -2.0, 0.0))
    rec = record_offline(tmp_path / 'r.mcap', Config(bodies=(anchor,)), 30, events={
        2: [Spawn(first)], 10: [Delete('b')], 20: [Spawn(second)]})
    assert replay.verify(rec.path).identical
    s = plots.body_series(rec)['b']
    early, late = s.t < 0.1, s.t > 0.195
    assert s.energy[early] == pytest.approx(0.5, rel=1e-12)
    assert s.energy[late] == pytest.approx(50.0, rel=1e-12)
    times, forces, _, _ = plots.wrench_steps(rec, 'b', 0.3)
    assert list(times) == pytest.approx([0.0, 0.01, 0.09, 0.19, 0.3])
    r = render.Renderer(rec, 'top', (200, 200))
    assert [p.primitive for p in r.timeline.life('b', 0.05)[1]] == ['sphere']
    assert [p.primitive for p in r.timeline.life('b', 0.25)[1]] == ['box']
    assert r.timeline.state('b', 0.15) is None  # deleted then


def _figures(monkeypatch, rec, out):
    """plots.plot(rec, out), and the figures it saved, by file name: each figure as it was
    written (its axes, lines and labels)."""
    from matplotlib.figure import Figure
    saved = {}
    save = Figure.savefig

    def keep(self, path, *args, **kwargs):
        saved[Path(path).name] = self
        return save(self, path, *args, **kwargs)

    monkeypatch.setattr(Figure, 'savefig', keep)
    plots.plot(rec, str(out))
    return saved


def _axes(fig, words):
    return [ax for ax in fig.axes if words in ax.get_title()]


def test_the_quaternion_is_plotted_without_hemisphere_jumps(tmp_path, monkeypatch):
    """A body turning about z at 1 turn/s for 1.5 s: each plotted quaternion sample is within
    the chord a publish's turn allows of the one before (q and -q are one rotation: the
    recorded w >= 0 jumps by 2 where it crosses 180 degrees), and each is the recorded
    rotation."""
    omega = 2.0 * np.pi
    spec = BodySpec('b', 1.0, (0.1,) * 3, initial_angular_velocity=(0.0, 0.0, omega))
    config = Config(dt=1e-3, steps_per_publish=10, bodies=(spec,))
    rec = record_offline(tmp_path / 'spin.mcap', config, 150)
    fig = _figures(monkeypatch, rec, tmp_path / 'p')['b.png']
    [ax] = _axes(fig, 'quaternion')
    q = np.array([line.get_ydata() for line in ax.get_lines()
                  if line.get_label() in 'xyzw']).T
    assert q.shape == (151, 4)
    chord = 2.0 * np.sin(omega * 0.01 / 4.0)  # a turn by theta: q moves theta / 2 on S^3
    assert np.linalg.norm(np.diff(q, axis=0), axis=1).max() < chord * (1 + 1e-6)
    recorded = plots.body_series(rec)['b'].quaternion
    assert np.abs(np.abs(np.sum(q * recorded, axis=1)) - 1.0).max() < 1e-12  # +-, the same
    # the continuous quaternion of the turn: w = cos(omega t / 2) from 1 through -1 (one turn,
    # t = 1 s: -q0), z = sin(omega t / 2)
    t = np.arange(151) * 0.01
    assert q[:, 3] == pytest.approx(np.cos(omega * t / 2.0), abs=1e-9)
    assert q[:, 2] == pytest.approx(np.sin(omega * t / 2.0), abs=1e-9)


def test_the_wrench_is_plotted_as_force_in_n_and_torque_in_n_m(tmp_path, monkeypatch):
    spec = BodySpec('b', 2.0, (0.1, 0.2, 0.3))
    config = Config(dt=1e-3, steps_per_publish=10, bodies=(spec,))
    rec = record_offline(tmp_path / 'w.mcap', config, 30, events={
        10: [SetWrench(Wrench((4.0, 0.0, 0.0), (0.0, 0.0, 0.5)), 'b')]})
    fig = _figures(monkeypatch, rec, tmp_path / 'p')['b.png']
    [force], [torque] = _axes(fig, 'force'), _axes(fig, 'torque')
    assert force is not torque
    assert '(N,' in force.get_title() and force.get_ylabel() == 'N'
    assert '(N m,' in torque.get_title() and torque.get_ylabel() == 'N m'
    assert 'N m' not in force.get_title()
    # each holds its own quantity: Fx 4 N, Tz 0.5 N m, from the step it took effect
    highs = {ax: max(float(np.max(line.get_ydata())) for line in ax.get_lines()
                     if line.get_label() in 'xyz') for ax in (force, torque)}
    assert highs == {force: 4.0, torque: 0.5}


def test_plot_memory_is_floats_a_publish_not_messages(tmp_path, monkeypatch):
    """replay --plot keeps 14 floats a publish of a body (what its panels need), not the
    messages, and draws a long run's lines as their envelope, at most MAX_LINE_POINTS points
    a line with every extreme kept: over 9,000 more publishes its heap grows by less than
    400 bytes a publish (it was 950: a tuple of Python floats a publish and matplotlib's
    copies of every sample)."""
    import tracemalloc
    spec = BodySpec('b', 1.0, (0.1, 0.2, 0.3), initial_angular_velocity=(0.3, 1.0, 2.0))
    config = Config(dt=1e-3, steps_per_publish=1, bodies=(spec,))
    short = record_offline(tmp_path / 'short.mcap', config, 3000)
    long = record_offline(tmp_path / 'long.mcap', config, 12000)
    plots.plot(short, str(tmp_path / 'warm'))  # (imports and caches out of the count)

    def peak(rec, out):
        tracemalloc.start()
        try:
            plots.plot(rec, str(out))
            return tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()

    grown = peak(long, tmp_path / 'l') - peak(short, tmp_path / 's')
    assert grown < 400 * 9000, grown
    fig = _figures(monkeypatch, long, tmp_path / 'f')['b.png']
    series = plots.body_series(long)['b']
    [ax] = _axes(fig, 'angular velocity')
    for k, line in enumerate(ax.get_lines()[:3]):
        y = line.get_ydata()
        assert len(y) <= plots.MAX_LINE_POINTS
        assert (y.min(), y.max()) == (series.angular[:, k].min(), series.angular[:, k].max())
        assert np.all(np.diff(line.get_xdata()) > 0)  # in time order


def test_the_envelope_keeps_every_run_s_extremes():
    t = np.arange(100_000) * 1e-3
    y = np.sin(t)
    y[12_345] = 50.0  # a spike
    y[70_000:70_010] = np.nan
    et, ey = plots.envelope(t, y)
    assert len(et) <= plots.MAX_LINE_POINTS and et[0] == t[0] and et[-1] == t[-1]
    assert 50.0 in ey and np.nanmin(ey) == np.nanmin(y)
    assert np.all(np.diff(et) > 0) and np.all(ey[~np.isnan(ey)] == np.interp(
        et[~np.isnan(ey)], t, y))  # samples of the line, not new points


@pytest.mark.parametrize('view, rotation, ratio', [
    ('side', (0.0, math.sin(math.pi / 4), 0.0, math.cos(math.pi / 4)), 3.0),  # lying along x
    ('side', (0.0, 0.0, 0.0, 1.0), 1.0 / 3.0),                                  # standing
    ('top', (0.0, 0.0, 0.0, 1.0), 1.0)])                                        # its cap
def test_a_cylinder_is_drawn_as_its_outline(tmp_path, view, rotation, ratio):
    """A cylinder 0.6 m long of radius 0.1, drawn alone: seen from the side lying, a
    rectangle three times as wide as high; standing, a third; from above standing, its cap,
    a disc as wide as high (the outline of its two rims)."""
    can = BodySpec('can', 1.0, (0.01,) * 3, initial_position=(0.0, 0.0, 1.0),
                   initial_orientation_xyzw=rotation, colliders=(Cylinder(0.1, 0.6),))
    rec = record_offline(tmp_path / 'r.mcap', Config(bodies=(can,)), 1)
    r = render.Renderer(rec, view, (400, 400))
    width, height = _spans(_coloured(r.frame(0.0)))
    assert width / height == pytest.approx(ratio, rel=0.05)


@pytest.mark.parametrize('view, ratio', [('side', 3.0), ('top', 3.0 / 2.0)])
def test_a_hull_is_drawn_as_its_faces(tmp_path, view, ratio):
    """The hull of a 0.6 x 0.4 x 0.2 m block's corners, drawn alone: from the side a
    rectangle three times as wide as high, from above 3 / 2 (its lit faces fill its outline)."""
    corners = [[x, y, z] for x in (-0.3, 0.3) for y in (-0.2, 0.2) for z in (-0.1, 0.1)]
    block = BodySpec('block', 1.0, (0.01,) * 3, initial_position=(0.0, 0.0, 1.0),
                     colliders=(Hull(corners),))
    rec = record_offline(tmp_path / 'r.mcap', Config(bodies=(block,)), 1)
    r = render.Renderer(rec, view, (400, 400))
    mask = _coloured(r.frame(0.0))
    width, height = _spans(mask)
    assert width / height == pytest.approx(ratio, rel=0.05)
    rows, cols = np.nonzero(mask)  # filled, not an outline
    assert mask.sum() > 0.8 * (np.ptp(rows) + 1) * (np.ptp(cols) + 1)
