"""scripts/python_benchmark.py runs, its --json output has the documented
format (a doc generator reads it), and docs/python.md's table is what its
stored run gives. Its timings are not checked: they are machine facts; only
their consistency is."""

import json
import os
import statistics
import subprocess
import sys


def test_benchmark_json_reports_medians_of_interleaved_pairs(source):
    result = subprocess.run([sys.executable, str(source / "scripts" / "python_benchmark.py"), "--rows", "3000",
                             "--python-rows", "200", "--repeat", "3", "--json"],
                            capture_output=True, text=True, env=dict(os.environ))
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert set(report) == {"bank", "modes", "repeat", "imm_run", "python_model", "machine", "load"}
    assert set(report["machine"]) == {"cpu", "cores", "python", "numpy"} and len(report["load"]) == 2
    assert (report["bank"], report["modes"], report["repeat"]) == ("ltc_terrains", 3, 3)
    run = report["imm_run"]
    assert set(run) == {"rows", "loop_seconds", "run_seconds", "ratio", "ratios"}
    assert run["rows"] == 3000 and len(run["ratios"]) == 3
    assert run["ratio"] == statistics.median(run["ratios"])
    assert run["loop_seconds"] > 0 and run["run_seconds"] > 0
    model = report["python_model"]
    assert set(model) == {"rows", "compiled_us_per_step", "python_us_per_step", "us_per_call", "ratio", "ratios"}
    assert model["rows"] == 200 and len(model["ratios"]) == 3
    assert model["ratio"] == statistics.median(model["ratios"])
    assert model["compiled_us_per_step"] > 0 and model["python_us_per_step"] > 0


def test_benchmark_refuses_an_empty_run(source):
    result = subprocess.run([sys.executable, str(source / "scripts" / "python_benchmark.py"), "--rows", "0"],
                            capture_output=True, text=True, env=dict(os.environ))
    assert result.returncode == 2 and "--rows" in result.stderr


def test_the_pages_table_is_what_the_stored_run_gives(source):
    result = subprocess.run([sys.executable, str(source / "scripts" / "python_benchmark.py"), "--check"],
                            capture_output=True, text=True, env=dict(os.environ))
    assert result.returncode == 0, result.stderr
