"""The tour of docs/python.md runs, draws its figure, and prints the numbers the page quotes."""

import os
import subprocess
import sys

import pytest


def test_tour_script_reproduces_the_pages_numbers(tmp_path, source):
    pytest.importorskip("matplotlib")
    figure = tmp_path / "tour.png"
    result = subprocess.run([sys.executable, str(source / "scripts" / "python_tour.py"), "--output", str(figure)],
                            capture_output=True, text=True, env=dict(os.environ))
    assert result.returncode == 0, result.stderr
    assert figure.stat().st_size > 10_000
    page = (source / "docs" / "python.md").read_text()
    for line in result.stdout.splitlines():
        if not line.startswith("wrote "):
            assert line in page, f"docs/python.md does not quote: {line}"
