# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
# pypi-only: mcap
"""replay --render's GIF plays in real time (issue 28): every frame's delay is a whole number
of centiseconds, at least 20 ms (what viewers play as written), and the delays add up to the
run's length within one frame; a GIF too large to hold is thinned, in one line. A recording
of bodies at +-1.7e308 m, or of a body whose inertia box is infinite, is drawn and plotted
as far as it can be, or refused in one line: never a traceback."""

import contextlib
import io

import numpy as np
import pytest

from oracles.node_recording import record_offline
from rb_sim_ros.offline import replay
from rb_sim_ros.pictures import plots, render
from rb_sim_ros.sim.simulation import BodySpec, Config


def spinning(dt=1e-3, steps_per_publish=10):
    return Config(dt=dt, steps_per_publish=steps_per_publish, bodies=(BodySpec(
        'b', 1.0, (0.1, 0.2, 0.3), initial_linear_velocity=(1.0, 0.0, 0.0),
        initial_angular_velocity=(0.0, 0.0, 2.0)),))


def delays(path):
    from PIL import Image, ImageSequence
    with Image.open(path) as im:
        return [frame.info['duration'] for frame in ImageSequence.Iterator(im)]


@pytest.mark.parametrize('dt, steps, fps', [
    (1e-3, 10, None), (1e-3, 15, None), (1e-3, 7, None), (1e-3, 1, None), (1e-3, 30, None),
    (1e-3, 10, 30.0), (1e-3, 10, 100.0), (1e-3, 10, 25.0)])
def test_a_gif_plays_in_real_time_in_whole_centiseconds(tmp_path, dt, steps, fps):
    rec = record_offline(tmp_path / 'r.mcap', spinning(dt, steps), round(1.5 / (dt * steps)))
    length = 1000.0 * dt * steps * round(1.5 / (dt * steps))  # ms
    gif = tmp_path / 'r.gif'
    n = render.render(rec, str(gif), 'top', fps=fps, size=(64, 64))
    d = delays(gif)
    assert len(d) == n
    assert all(x % 10 == 0 and x >= 20 for x in d), d
    assert abs(sum(d) - length) <= max(d), (sum(d), length)
    assert sum(d) >= length  # the last frame is shown too
    if fps is not None and fps <= 50:
        assert n == int(length / 1000.0 * fps + 1e-9) + 1  # every frame asked for


def test_a_gif_too_large_to_hold_is_thinned_in_one_line(tmp_path, monkeypatch, capsys):
    rec = record_offline(tmp_path / 'r.mcap', spinning(), 150)
    monkeypatch.setattr(render, 'MAX_GIF_PIXELS', 64 * 64 * 10)
    gif = tmp_path / 'r.gif'
    n = render.render(rec, str(gif), 'top', size=(64, 64))
    d = delays(gif)
    assert len(d) == n <= 10
    assert all(x % 10 == 0 and x >= 20 for x in d) and abs(sum(d) - 1500) <= max(d)
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and 'every' in err and '--fps' in err, err


def _main(*args):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = replay.main(['replay', *args])
        except SystemExit as e:
            code = e.code
    return code, out.getvalue(), err.getvalue()


@pytest.mark.parametrize('spec', [
    BodySpec('b', 1.0, (0.1,) * 3, initial_position=(1.7e308, 0.0, 0.0)),
    BodySpec('b', 1.0, (0.1,) * 3, initial_position=(-1.7e308, 1.7e308, -1.7e308)),
    BodySpec('b', 1.0, (0.1,) * 3, initial_position=(0.0, 0.0, 1.7e308),
             initial_linear_velocity=(0.0, 0.0, -1e308)),
    BodySpec('b', 2.3e-308, (1e10,) * 3),
], ids=['x', 'xyz', 'falling', 'tiny_mass'])
def test_extreme_bodies_are_drawn_and_plotted_or_refused_in_one_line(tmp_path, spec):
    near = BodySpec('near', 1.0, (0.1,) * 3)
    rec = record_offline(tmp_path / 'r.mcap', Config(bodies=(spec, near)), 5)
    for args in (('--render', rec.path, str(tmp_path / 'r.gif'), '--size', '64x64'),
                 ('--render', rec.path, str(tmp_path / 'f.gif'), '--follow', 'b', '--size',
                  '64x64'),
                 ('--plot', rec.path, '--out', str(tmp_path / 'p'))):
        code, out, err = _main(*args)
        assert 'Traceback' not in err and code in (0, 2), (args, code, err)
        if code == 2:
            assert err.count('\n') == 1 and "'b'" in err, (args, err)
        else:  # whatever it leaves out is said, one line a body and quantity
            assert all(line.startswith(('replay: ', 'render: ', 'plot: '))
                       for line in err.splitlines() if line), err
    files = plots.plot(rec, str(tmp_path / 'q'), ['near'])
    assert files


def test_a_gif_delay_longer_than_a_gif_holds_is_capped():
    """A GIF stores a delay in 16 bits of centiseconds: a frame a day long is shown 655.35 s,
    not an OverflowError from the writer."""
    times, delays = render.gif_frames(np.array([0.0, 86_400.0, 172_800.0]), 8, 8)
    assert len(times) == 3 and max(delays) == 655_350 and min(delays) >= 20
