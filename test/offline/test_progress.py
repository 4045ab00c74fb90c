# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Progress of the offline tools: a tqdm bar on a terminal, whole lines elsewhere (a pipe or a
log file gets no carriage returns and no line per item)."""

import io

from rb_sim_ros.offline.progress import Progress


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_a_pipe_gets_whole_lines_and_one_at_the_end():
    out = io.StringIO()
    p = Progress(1000, 'replay: rendering frame', stream=out, plain_every=3600.0)
    for i in range(1, 1001):
        p(i)
    p.close()
    text = out.getvalue()
    assert '\r' not in text
    assert text.splitlines() == ['replay: rendering frame: 1000/1000 (100.0%)']


def test_a_pipe_gets_a_line_each_period_with_the_share_done():
    out = io.StringIO()
    p = Progress(4, 'sweep', 'runs', stream=out, plain_every=0.0)
    for i in range(1, 5):
        p(i)
    p.close()
    lines = out.getvalue().splitlines()
    # The first call only starts the clock; then a line each call (period 0), then the end.
    assert [line.split(':')[1].split()[0] for line in lines] == ['2/4', '3/4', '4/4', '4/4']
    assert '(50.0%)' in lines[0] and 'runs' in lines[0]


def test_a_terminal_gets_a_tqdm_bar():
    out = _Terminal()
    p = Progress(10, 'replay', stream=out)
    for i in range(1, 11):
        p(i)
    p.close()
    text = out.getvalue()
    assert '\r' in text and '100%' in text and '10/10' in text
