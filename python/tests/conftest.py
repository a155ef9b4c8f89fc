"""Shared fixtures: the source tree, the `skidimm` executable of the same
build (to compare with), and simulated logs made once per session."""

import os
import pathlib
import subprocess

import pytest

import skidimm

SOURCE = pathlib.Path(os.environ.get("SKIDIMM_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
CONFIGS = SOURCE / "configs"


def _executable():
    given = os.environ.get("SKIDIMM_EXECUTABLE")
    if given:
        return pathlib.Path(given)
    # The build tree mirrors the install tree: <root>/lib/skidimm/plugins and <root>/bin/skidimm.
    return pathlib.Path(skidimm.module_plugin_directory()).parents[2] / "bin" / "skidimm"


@pytest.fixture(scope="session")
def source():
    return SOURCE


@pytest.fixture(scope="session")
def configs():
    return CONFIGS


@pytest.fixture(scope="session")
def cli():
    """Runs the `skidimm` tool; returns its stdout."""
    executable = _executable()
    if not executable.exists():
        pytest.skip(f"no skidimm executable at {executable}")

    def run(*arguments):
        result = subprocess.run([str(executable), *map(str, arguments)], capture_output=True, text=True)
        assert result.returncode == 0, result.stderr
        return result.stdout

    return run


@pytest.fixture(scope="session")
def switching_logs(tmp_path_factory):
    """24 short simulated runs of the paper's terrain-switching scenario, one directory."""
    directory = tmp_path_factory.mktemp("switching")
    for seed in range(24):
        skidimm.simulate(CONFIGS / "scenarios" / "ltc_switching.yaml", seed=7000 + seed, duration=14.0,
                         output=directory / f"run_{seed:02d}.csv")
    return directory


@pytest.fixture(scope="session")
def singular_logs(tmp_path_factory):
    """Labelled single-terrain runs for fitting: {terrain: [paths]}."""
    directory = tmp_path_factory.mktemp("singular")
    logs = {}
    for terrain in ("asphalt", "grass"):
        for seed in (1, 2):
            path = directory / f"{terrain}_{seed}.csv"
            skidimm.simulate(CONFIGS / "scenarios" / f"ltc_singular_{terrain}.yaml", seed=seed, duration=8.0,
                             output=path)
            logs.setdefault(terrain, []).append(path)
    return logs
