# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Every source file carries the project's copyright and license lines (what ament_copyright
checks in the ament templates), and LICENSE is the Apache-2.0 text package.xml names."""

from pathlib import Path
import subprocess
import xml.etree.ElementTree as ET

ROOT = Path(__file__).resolve().parents[2]
HEADER = ('# Copyright 2026 The rb_sim_ros Authors',
          '# Licensed under the Apache License, Version 2.0')


def _sources():
    listed = subprocess.run(['git', 'ls-files', '*.py'], cwd=ROOT, capture_output=True,
                            text=True)
    if listed.returncode == 0 and listed.stdout.strip():
        return [ROOT / p for p in listed.stdout.split()]
    return [p for d in ('rb_sim_ros', 'test', 'bench', 'oracles', 'tools', 'launch')
            for p in (ROOT / d).rglob('*.py')] + [ROOT / 'setup.py']  # not a git clone


def test_every_source_file_has_the_copyright_and_license_lines():
    missing = []
    for path in _sources():
        lines = path.read_text().splitlines()
        start = 1 if lines and lines[0].startswith('#!') else 0
        if tuple(lines[start:start + 2]) != HEADER:
            missing.append(str(path.relative_to(ROOT)))
    assert not missing, f'without the two header lines: {missing}'


def test_license_file_is_the_apache_2_text_package_xml_names():
    text = (ROOT / 'LICENSE').read_text()
    assert 'Apache License' in text and 'Version 2.0, January 2004' in text
    assert 'END OF TERMS AND CONDITIONS' in text and len(text.splitlines()) > 190
    assert ET.parse(ROOT / 'package.xml').find('license').text == 'Apache-2.0'
