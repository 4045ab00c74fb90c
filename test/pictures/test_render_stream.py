# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
# pypi-only: mcap
"""replay --render writes a GIF a frame at a time (issue 28, N06): the memory it holds does not
grow with the number of frames, and the file read back by Pillow shows the frames drawn, with
the delays the real-time rule gives."""

import re
import tracemalloc

import numpy as np
import pytest

from oracles.node_recording import record_offline
from rb_sim_ros.pictures import render
from rb_sim_ros.sim.simulation import BodySpec, Config

SIZE = (320, 240)


def spinning(tmp_path, periods):
    """A box turning and moving across the view, published at 50 Hz (every publish is a frame
    of the GIF: 20 ms, the least delay)."""
    config = Config(dt=1e-3, steps_per_publish=20, bodies=(BodySpec(
        'b', 1.0, (0.1, 0.2, 0.3), initial_linear_velocity=(1.0, 0.0, 0.0),
        initial_angular_velocity=(0.0, 0.0, 2.0)),))
    return record_offline(tmp_path / f'r{periods}.mcap', config, periods)


def _held(rec, path):
    """(frames, the most Pillow image blocks alive while rendering, the Python heap's peak
    bytes): Pillow keeps image pixels in blocks of its own, outside tracemalloc's view."""
    from PIL import Image
    stats = Image.core.get_stats

    def live():
        s = stats()
        return s['allocated_blocks'] + s['reused_blocks'] - s['freed_blocks'] - \
            s['blocks_cached']

    most = [live()]
    base = most[0]
    tracemalloc.start()
    try:
        n = render.render(rec, str(path), 'top', size=SIZE,
                          progress=lambda done, total: most.append(live()))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    return n, max(most) - base, peak


def test_the_memory_a_gif_needs_does_not_grow_with_its_frames(tmp_path):
    short, long = spinning(tmp_path, 25), spinning(tmp_path, 100)
    n1, blocks1, peak1 = _held(short, tmp_path / 'short.gif')
    n4, blocks4, peak4 = _held(long, tmp_path / 'long.gif')
    assert (n1, n4) == (26, 101)
    # Holding every frame would be a block a frame (26, then 101): a frame at a time it is
    # the same few blocks however long the run.
    assert blocks1 <= 6 and blocks4 <= blocks1, (blocks1, blocks4)
    # and the Python heap grows far less than the frames: 75 more frames of 320x240 held as
    # bytes would be 5.8 MB; what grows is the timeline's floats and the recording's reader
    # (a chunk of messages, some 300 kB here, bounded by the chunk size, not the length).
    assert peak4 - peak1 < 0.2 * 75 * SIZE[0] * SIZE[1], (peak1, peak4)


def test_the_gif_read_back_shows_the_frames_drawn_with_their_delays(tmp_path):
    """Each frame of the file is written as the rectangle that changed since the one before:
    composed by Pillow's reader, every frame is the frame drawn (up to the 64 colours of a GIF
    frame), and the delays are those of gif_frames."""
    from PIL import Image, ImageSequence
    rec = spinning(tmp_path, 40)
    gif = tmp_path / 'r.gif'
    n = render.render(rec, str(gif), 'top', size=SIZE)
    r = render.Renderer(rec, 'top', SIZE)
    times, delays = render.gif_frames(render._frame_times(r.timeline, None), *SIZE)
    assert n == len(times) == 41
    with Image.open(gif) as im:
        assert im.n_frames == n and im.info.get('loop') == 0
        got_delays = []
        for k, frame in enumerate(ImageSequence.Iterator(im)):
            got_delays.append(frame.info['duration'])
            read = np.asarray(frame.convert('RGB')).astype(int)
            drawn = np.asarray(r.frame(float(times[k]))).astype(int)
            differ = np.any(np.abs(read - drawn) > 24, axis=2)
            assert differ.mean() < 0.002, (k, differ.sum())
    assert got_delays == delays
    assert sum(delays) == pytest.approx(1000 * (0.8 + 0.02), abs=10)  # 0.8 s, the last shown
    assert not list(tmp_path.glob('.render-*'))  # no part file left beside it


def test_a_frame_that_cannot_be_drawn_leaves_no_half_gif(tmp_path, monkeypatch):
    rec = spinning(tmp_path, 10)
    gif = tmp_path / 'r.gif'
    gif.write_bytes(b'before')
    calls = []

    def frame(self, t):
        calls.append(t)
        if len(calls) > 3:
            raise OverflowError('cannot convert float infinity to integer')
        return drawn(self, t)

    drawn = render.Renderer.frame
    monkeypatch.setattr(render.Renderer, 'frame', frame)
    with pytest.raises(ValueError, match='cannot be drawn'):
        render.render(rec, str(gif), 'top', size=SIZE)
    assert gif.read_bytes() == b'before' and not list(tmp_path.glob('.render-*'))


def test_an_output_that_cannot_be_written_is_one_line_naming_it(tmp_path):
    rec = spinning(tmp_path, 2)
    out = tmp_path / 'no such folder' / 'r.gif'
    with pytest.raises(ValueError, match='^' + re.escape(f'{out}: cannot write there')):
        render.render(rec, str(out), 'top', size=(64, 64))


def test_the_gif_gets_the_mode_of_any_new_file(tmp_path):
    rec = spinning(tmp_path, 2)
    gif, plain = tmp_path / 'r.gif', tmp_path / 'plain'
    plain.write_bytes(b'')
    render.render(rec, str(gif), 'top', size=(64, 64))
    assert gif.stat().st_mode == plain.stat().st_mode  # not the part file's 0600
