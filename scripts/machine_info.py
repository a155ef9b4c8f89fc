"""What the machine behind a measurement is, for the pages that state it
(performance_tables.py, python_benchmark.py import it)."""

import pathlib
import platform


def cpu_model():
    """The processor's name as /proc/cpuinfo gives it ("AMD EPYC ..."), else what platform knows."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return cpu
