# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
# pypi-only: mujoco
"""The benchmark suite's quick mode runs, so that it cannot rot. Nothing timed is asserted
(the machine is noisy): orders, agreement with the references, and the stress outcomes."""

import importlib
import json
import math
import os
from pathlib import Path
import re
import subprocess
import sys

import pytest

from rb_sim_ros import METHODS

ROOT = Path(__file__).resolve().parents[2]


def _bench(name):
    """A module of the bench package (the checkout's, on the path by test/conftest.py)."""
    module = importlib.import_module(f'bench.{name}')
    assert Path(module.__file__).parent == ROOT / 'bench', module  # not another 'bench'
    return module


def _run_bench(name, *args, timeout, env=None):
    """``python -m bench.<name> args`` from the repository root, as the docs say to run it."""
    return subprocess.run([sys.executable, '-m', f'bench.{name}', *args], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=timeout)


def test_the_report_keeps_the_written_part_of_the_benchmarks_page(tmp_path):
    """bench/report.py writes the top of docs/benchmarks.md; the figures of the other
    benchmarks below it (from "Accuracy and speed" on) are written by hand and must survive
    a regeneration, and the generated part is what report.py renders from run.json."""
    report = _bench('report')
    page = (ROOT / 'docs' / 'benchmarks.md').read_text() + 'A line written by hand.\n'
    assert report.WRITTEN in page
    summary = json.loads((ROOT / 'docs' / 'bench' / 'run.json').read_text())
    (tmp_path / 'benchmarks.md').write_text(page)
    assert page.startswith(report.render(summary).rstrip('\n') + '\n')  # as committed
    written = report.write(tmp_path, summary).read_text()
    assert written.startswith(report.render(summary).rstrip('\n') + '\n')
    assert written[written.index(report.WRITTEN):] == page[page.index(report.WRITTEN):]
    fresh = tmp_path / 'fresh'
    fresh.mkdir()
    assert report.write(fresh, summary).read_text() == report.render(summary)


@pytest.mark.slow  # a benchmark
def test_quick_benchmark_checks_orders_and_writes_its_report(tmp_path):
    result = _run_bench('run', '--quick', '--out', str(tmp_path), timeout=300)
    assert result.returncode == 0, result.stderr[-3000:]
    summary = json.loads((tmp_path / 'summary.json').read_text())
    assert summary['quick'] and summary['orders_checked'] and not summary.get('failures')

    for scene_name, scene in summary['work_precision'].items():
        assert scene['reference_check']['ok'], scene['reference_check']
        methods = scene['methods']
        assert {f'rb_sim_ros {m}' for m in METHODS} <= set(methods)
        assert {'MuJoCo Euler', 'MuJoCo implicitfast', 'MuJoCo RK4', 'scipy DOP853'} <= \
            set(methods)
        for name, data in methods.items():
            assert data['ok'], name
            if data['expected_order'] is not None:
                for what in ('angle', 'omega'):
                    if data.get(f'exact_{what}'):  # every error below 1e-10: a flow method,
                        # and only on the torque-free scenes (under torque it has an order)
                        assert name.startswith('rb_sim_ros flow'), (name, what)
                        assert scene_name != 'torque every 0.1 s', name
                        continue
                    assert abs(data[f'order_{what}'] - data['expected_order']) <= 0.3, \
                        (name, what, data[f'order_{what}'])
            timed = [p for p in data['points'] if 'diverged' not in p]
            assert timed and all(p['seconds_per_sim_second'] > 0 for p in timed)

    stress = summary['stress']
    for row in stress['blow_up']:
        if row['exact_flow']:  # exact at any rate: runs through, finite, energy kept
            assert not row['raised'] and row['finite'] and abs(row['energy_drift']) < 1e-12
        else:
            assert row['raised'] and row['consistent'] and row['state_finite'], row
    flip = stress['dzhanibekov']
    eq27 = next(r for r in flip['rows'] if r['method'] == 'rb_sim_ros eq27')
    assert abs(eq27['relative_error']) < 1e-3
    for case in stress['extreme_inertia']:
        ours = case['results']['rb_sim_ros eq27']
        assert ours['finite'] and ours['angle_max'] < 1e-2, (case['case'], ours)
    first = stress['fast_spin']['rows'][0]
    assert first['omega_dt'] == 0.01
    assert first['results']['rb_sim_ros eq27']['status'] == 'accurate'
    long_run = stress['long_run']['methods']['rb_sim_ros eq27']
    assert long_run['diverged'] is None
    assert long_run['max_orthonormality_error'] < 1e-12
    assert abs(long_run['energy_drift'][-1]) < 1e-6

    assert (tmp_path / 'benchmarks.md').read_text().startswith('# Benchmarks')
    pngs = {p.name for p in (tmp_path / 'img').glob('*.png')}
    assert {'fast_spin.png', 'long_run.png'} <= pngs
    assert len([p for p in pngs if p.startswith('work_precision_')]) == 4


def test_order_check_fails_loudly_on_a_method_off_its_order():
    wp = _bench('work_precision')
    dts = [0.01, 0.005, 0.0025, 0.00125]

    def scene(order):
        points = [{'dt': dt, 'angle_final': 0.1 * (dt / 0.01) ** order,
                   'omega_final': 0.1 * (dt / 0.01) ** order} for dt in dts]
        return {'s': {'scene': {'omega0': 1.0}, 'methods': {
            'a second-order method': {'expected_order': 2, 'points': points}}}}

    assert wp.check_orders(scene(2.0)) == []
    failures = wp.check_orders(scene(1.0))
    assert len(failures) == 2 and 'falls at order 1.00, expected 2' in failures[0]
    assert math.isclose(wp.fit_order(scene(2.0)['s']['methods']['a second-order method']
                                     ['points'], 'angle_final')['order'], 2.0)


def _quick(name: str, tmp_path: Path) -> dict:
    """Run python -m bench.<name> --quick (its checks and sanity checks must pass) and return
    the figures it wrote."""
    out = tmp_path / f'{name}.json'
    result = _run_bench(name, '--quick', '--json', str(out), timeout=300)
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    figures = json.loads(out.read_text())
    assert figures['quick'] and figures['command'].startswith(f'python -m bench.{name} ')
    return figures


@pytest.mark.slow  # a benchmark
def test_collision_benchmarks_pass_their_checks_in_quick_mode(tmp_path):
    """Their checks: both engines' heaps stay in the box and agree; the collision tests'
    scenarios stay within the bounds their tests assert; a resting floor of boxes stays put in
    every engine and all of it falls asleep; a drop wakes only what it hits; a cylinder
    rolls, rights itself and rests in both engines; a cradle passes its impact on."""
    collision = _quick('collision_bench', tmp_path)
    like = collision['mujoco']['PGS, 10 iterations']
    assert like['max_iterations'] == 10 and collision['rb_sim_ros']['iterations'] <= 10
    cases = _quick('collision_cases', tmp_path)
    assert cases['mixed']['bit_identical'] and len(cases['cells']) == 9
    resting = _quick('resting_bench', tmp_path)
    assert resting['asleep']['contacts'] == 0 and resting['awake']['contacts'] > 0
    assert 1 < resting['asleep']['awake_after_drop'] < 2 * resting['side'] ** 2
    assert resting['mujoco_sleeping']['awake_trees'] < 2 * resting['side'] ** 2
    contact = _quick('contact_step_bench', tmp_path)  # closed forms checked before timing
    assert set(contact['seconds_per_step']) == {'sliding box', 'bouncing ball', 'rolling ball',
                                                'tipping cube'}
    cylinder = _quick('cylinder_bench', tmp_path)  # both engines' outcomes checked first
    assert set(cylinder['seconds_per_step']) == {'rolling cylinder', 'tipping cylinder',
                                                 'cylinder on a box', 'crossed cylinders'}
    hull = _quick('hull_bench', tmp_path)  # both engines' outcomes checked first
    assert set(hull['seconds_per_step']) == {'tipping post', 'pebble on the ground',
                                             'hull on a hull', 'pebble on terrain'}
    pile = _quick('hull_pile_bench', tmp_path)  # every hull in the bin in every run
    assert pile['hulls'] == 16 and set(pile['seconds_per_step']) == {
        'rb_sim_ros', 'rb_sim_ros, terrain bin', 'MuJoCo Newton'}
    cradle = _quick('cradle_bench', tmp_path)  # ours within 2% of the ideal sequence
    required = {'rb_sim_ros', 'MuJoCo, elastic (solref -1e6 -1e-6)',
                'MuJoCo, default (solref 0.02 1)'}
    optional = {'PyBullet', 'Drake (point contact, no dissipation)'}  # requirements-peers.txt
    assert required <= set(cradle['cradles']['3']) <= required | optional
    # every plate caught, no ghost stop with the swept test, some without it
    ccd = _quick('ccd_bench', tmp_path)
    assert ccd['tunnelling']['passed']['default'] == 0 and ccd['ghosts']['stopped_without'] > 0


@pytest.mark.slow  # a benchmark
def test_step_benchmarks_pass_their_checks_in_quick_mode(tmp_path):
    """Every path agrees with its reference before it is timed, and every figure is sane."""
    step = _quick('step_cost', tmp_path)
    assert {r['call'] for r in step['rows']} == {'step(1)', 'step(10)', 'amortised'}
    skip = _quick('skip_bench', tmp_path)
    assert all(r['agreement'] <= 1e-12 for r in skip['rows'])
    batch = _quick('batch_bench', tmp_path)
    assert batch['batch_vs_steppers'] < 1e-12


@pytest.mark.slow  # a benchmark
def test_node_timing_passes_its_checks_in_quick_mode(tmp_path):
    """The moving body's last pose matches an offline Stepper; the figures are plausible."""
    node = _quick('node_timing', tmp_path)
    fastest = node['fastest'][0]
    assert fastest['body'] == 'spinning, full tensor' and fastest['pose_error'] <= 1e-9


@pytest.mark.slow  # a benchmark
def test_node_lifecycle_passes_its_checks_in_quick_mode():
    """A 200-body scene starts and publishes all its poses; two stops by signal at full
    speed exit 0 without a traceback and leave recordings that verify."""
    env = dict(os.environ)
    env.setdefault('AMENT_PREFIX_PATH', sys.prefix)
    result = _run_bench('node_lifecycle', '--quick', timeout=600, env=env)
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    assert 'start-up, 200 bodies' in result.stdout and '2 of 2 clean' in result.stdout


def test_every_quoted_figure_is_in_the_committed_benchmark_output():
    """docs/benchmarks.md and the other docs quote only what docs/bench/*.json holds
    (bench/figures.py says where and how each figure is formatted): a stale figure fails
    here."""
    figures = _bench('figures')
    assert figures.stale() == []


FIGURES_DOC = 'docs/benchmarks.md'
# A number with the unit of something measured: a time, a ratio, a share, a size, a speed.
MEASURED = re.compile(r'(?<![\w.])(\d[\d,]*(?:\.\d+)?) ?(?:ms|us|ns|s|min|x|%|MB|MiB|GB|kB|km/s)'
                      r'(?![\w/])')


def _numbers(text):
    return re.findall(r'\d+(?:\.\d+)?', text.replace(',', ''))


def test_every_number_of_the_accuracy_and_speed_table_is_accounted_for():
    """Each number in a row of the "Accuracy and speed" table of docs/benchmarks.md that cites
    a benchmark is one of the texts bench/figures.py derives for that row from the committed
    JSON."""
    figures = _bench('figures')
    text = (ROOT / FIGURES_DOC).read_text()
    table = [line for line in figures.section(text, 'Accuracy and speed').splitlines()
             if line.startswith('| ') and '`python -m bench.' in line]
    assert len(table) >= 8
    quotes = figures.quotes()
    for line in table:
        what, value = line.split(' | ')[0:2]
        expected = ' '.join(text for doc, anchor, text in quotes
                            if doc == FIGURES_DOC and anchor in what)
        for number in re.findall(r'\d+(?:\.\d+)?', value):
            assert number in re.findall(r'\d+(?:\.\d+)?', expected) or number in \
                re.findall(r'\d+(?:\.\d+)?', what), (line, number, expected)


def _paragraphs(text):
    """Paragraphs (a list item is one), whitespace made single spaces; tables left out."""
    out, lines = [], []
    for line in text.splitlines() + ['']:
        if not line.strip() or line.startswith(('#', '|', '- ')):
            if lines:
                out.append(' '.join(' '.join(lines).split()))
            lines = [line] if line.startswith('- ') else []
        else:
            lines.append(line)
    return out


def test_every_measured_figure_of_the_hand_written_sections_is_accounted_for():
    """In the sections of docs/benchmarks.md after those bench/report.py writes, a paragraph
    that cites a benchmark writing docs/bench/<name>.json quotes, as a time, ratio, share, size
    or speed, only numbers that bench/figures.py derives from the committed JSON: a figure
    added by hand, or left from another run, fails here even where no anchor names it."""
    figures = _bench('figures')
    text = (ROOT / FIGURES_DOC).read_text()
    hand = text[text.index('\n## Accuracy and speed\n'):]
    known = set(_numbers(' '.join(t for doc, anchor, t in figures.quotes()
                                  if doc == FIGURES_DOC)))
    checked = 0
    for paragraph in _paragraphs(hand):
        cited = re.findall(r'python -m bench\.(\w+)', paragraph)
        if not any((ROOT / 'docs' / 'bench' / f'{name}.json').exists() for name in cited):
            continue
        checked += 1
        for number in MEASURED.findall(paragraph):
            assert number.replace(',', '') in known, (number, paragraph)
    assert checked >= 8


def test_the_readme_quotes_no_measured_figure():
    """README.md says in words what the simulator is and links to docs/benchmarks.md for the
    figures, which drift: none of the texts bench/figures.py checks, and no time, ratio, share
    or size of a measurement (a start of 8 s of sim time or a default is no measurement)."""
    figures = _bench('figures')
    readme = ' '.join((ROOT / 'README.md').read_text().split())
    for doc, anchor, text in figures.quotes():
        assert ' '.join(text.split()) not in readme, (doc, anchor, text)
    measured = [m.group(0) for m in MEASURED.finditer(readme)
                if not re.fullmatch(r'\d s', m.group(0))]
    assert measured == []
    assert len((ROOT / 'README.md').read_text().splitlines()) <= 150
    assert '\n    ./tools/test.sh\n' in (ROOT / 'README.md').read_text()  # what .ci/run runs


def _slug(title):
    """GitHub's anchor of a markdown heading."""
    title = re.sub(r'[^\w\- ]', '', title.strip().lower())
    return title.replace(' ', '-')


def test_every_link_of_the_readme_and_the_docs_resolves():
    """Relative links of README.md and docs/*.md name a file that exists and, after '#', a
    heading of it: the manual moved out of the README, and its anchors with it."""
    docs = [ROOT / 'README.md', *sorted((ROOT / 'docs').glob('*.md'))]
    links = 0
    for doc in docs:
        for target in re.findall(r'\]\(([^)\s]+)\)', doc.read_text()):
            if re.match(r'[a-z]+:', target):
                continue
            path, _, anchor = target.partition('#')
            file = (doc.parent / path).resolve() if path else doc
            assert file.exists(), (doc.name, target)
            if anchor:
                headings = [_slug(line.lstrip('#')) for line in file.read_text().splitlines()
                            if line.startswith('#')]
                assert anchor in headings, (doc.name, target)
            links += 1
    assert links >= 20


def test_what_points_to_a_readme_section_names_one():
    """A string of the package, its tools, examples or config that sends a user to a section
    of the README (README, "Title") names a heading the README has."""
    headings = [line.lstrip('#').strip() for line in
                (ROOT / 'README.md').read_text().splitlines() if line.startswith('#')]
    for folder in ('rb_sim_ros', 'tools', 'examples', 'config', 'launch'):
        for path in (ROOT / folder).rglob('*'):
            if path.suffix not in ('.py', '.sh', '.yaml', '.md') or '__pycache__' in path.parts:
                continue
            for title in re.findall(r'README(?:\.md)?,? "([^"]+)"', path.read_text()):
                assert any(h.startswith(title) for h in headings), (path, title)


def test_every_benchmark_json_names_its_command():
    for path in sorted((ROOT / 'docs' / 'bench').glob('*.json')):
        data = json.loads(path.read_text())
        assert re.fullmatch(rf'python -m bench\.{path.stem}( .*)?', data['command']), path
        assert not data['quick'], path
