"""The bundled switching example (configs/examples/ltc_switching.csv) as the arrays a bank steps on."""

import numpy as np

import skidimm

EXAMPLE = "examples/ltc_switching.csv"


def arrays(configs, bank):
    """(t, u, z): the example's times, and its inputs and measurements in the bank's order."""
    log = skidimm.read_csv(configs / EXAMPLE)
    u = np.column_stack([log[c] for c in bank.inputs])
    z = np.column_stack([log[c] for c in bank.measurements])
    return log["t"], u, z
