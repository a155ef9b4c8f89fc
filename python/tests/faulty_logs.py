"""Logs with a fault a bank may be told to leave out, for the tests of what each front end says of it."""


def a_row_written_twice(configs, switching_logs, directory):
    """run_02 with its row 300 again as line 302, and the terrains bank that leaves such rows out: (log, bank)."""
    lines = (switching_logs / "run_02.csv").read_text().splitlines(keepends=True)
    twice = directory / "twice.csv"
    twice.write_text("".join(lines[:301] + [lines[300]] + lines[301:]))
    bank = directory / "lenient.yaml"
    bank.write_text((configs / "ltc_terrains.yaml").read_text() + "\nsampling:\n  skip_out_of_order: true\n")
    return twice, bank
