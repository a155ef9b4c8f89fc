"""step and run from Python against each other and against `skidimm run`."""

import threading
import warnings

import numpy as np
import pytest

import skidimm

EXAMPLE = "examples/ltc_switching.csv"


def arrays(configs, bank):
    log = skidimm.read_csv(configs / EXAMPLE)
    t = log["t"]
    u = np.column_stack([log[c] for c in bank.inputs])
    z = np.column_stack([log[c] for c in bank.measurements])
    return log, t, u, z


def cli_run(cli, tmp_path, configs, *extra):
    out = tmp_path / "cli.csv"
    cli("run", "--bank", configs / "ltc_terrains.yaml", "--input", configs / EXAMPLE, "--output", out, "--quiet",
        *extra)
    return skidimm.read_csv(out)


def test_run_over_arrays_equals_the_cli_exactly(tmp_path, configs, cli):
    bank = skidimm.Bank(configs / "ltc_terrains.yaml")
    log, t, u, z = arrays(configs, bank)
    out = skidimm.Imm(bank).run(t, u, z, truth=log["mode"])
    assert_columns_equal(out, cli_run(cli, tmp_path, configs))


def assert_columns_equal(out, expected):
    assert list(out) == list(expected)  # every column, in the CLI's order
    for name, column in expected.items():
        if column.dtype == object:
            assert list(out[name]) == list(column), name
        else:
            np.testing.assert_array_equal(out[name], column, err_msg=name)  # shortest round-trip text: exact


@pytest.mark.parametrize("smoothing", [[], ["--lag", "1.5"]])
def test_rows_with_a_reason_equal_the_cli(tmp_path, configs, cli, smoothing):
    # A tight innovation gate turns measurements away from some modes on some
    # rows: those rows, and only those, say why in the reason column.
    bank_file = tmp_path / "gated.yaml"
    bank_file.write_text((configs / "ltc_terrains.yaml").read_text() + "\ninnovation_gate: 0.9\n")
    bank = skidimm.Bank(bank_file)
    log, t, u, z = arrays(configs, bank)
    lag = {"lag": float(smoothing[1])} if smoothing else {}
    out = skidimm.Imm(bank).run(t, u, z, truth=log["mode"], **lag)
    expected = tmp_path / "cli.csv"
    cli("run", "--bank", bank_file, "--input", configs / EXAMPLE, "--output", expected, "--quiet", *smoothing)
    expected = skidimm.read_csv(expected)
    reasons = [r for r in expected["reason"] if r]
    assert 0 < len(reasons) < len(expected["reason"]) and all("gated (NIS" in r for r in reasons)
    assert_columns_equal(out, expected)
    assert_columns_equal(skidimm.run_log(bank, configs / EXAMPLE, **lag), expected)


@pytest.mark.parametrize("smoothing", [{"smooth": True}, {"lag": 1.5}])
def test_smoothed_runs_equal_the_cli(tmp_path, configs, cli, smoothing):
    bank = skidimm.Bank(configs / "ltc_terrains.yaml")
    log, t, u, z = arrays(configs, bank)
    out = skidimm.Imm(bank).run(t, u, z, **smoothing)
    extra = ["--smooth"] if "smooth" in smoothing else ["--lag", smoothing["lag"]]
    expected = cli_run(cli, tmp_path, configs, *extra)
    for name in ["mu_asphalt", "mu_grass", "V", "var_omega"]:
        np.testing.assert_array_equal(out[name], expected[name], err_msg=name)
    assert list(out["decision"]) == list(expected["decision"])


@pytest.mark.parametrize("smoothing", [[], ["--smooth"], ["--lag", "1.5"]])
def test_an_unknown_hypothesis_is_carried_as_the_cli_carries_it(tmp_path, configs, cli, smoothing):
    # Rows 300-309 measured far from every mode: "none of these" takes them,
    # its probability is a column after the modes', and `mode` says unknown.
    bank_file = tmp_path / "unknown.yaml"
    bank_file.write_text((configs / "ltc_terrains.yaml").read_text() +
                         "\nunknown: {inflation: 100, enter: 0.01, leave: 0.2}\n")
    lines = (configs / EXAMPLE).read_text().splitlines()
    header = lines[0].split(",")
    v = header.index("V")
    for row in range(301, 311):
        cells = lines[row].split(",")
        cells[v] = "40"
        lines[row] = ",".join(cells)
    log_file = tmp_path / "far.csv"
    log_file.write_text("\n".join(lines) + "\n")
    bank = skidimm.Bank(bank_file)
    log = skidimm.read_csv(log_file)
    t = log["t"]
    u = np.column_stack([log[c] for c in bank.inputs])
    z = np.column_stack([log[c] for c in bank.measurements])
    options = {"smooth": True} if smoothing == ["--smooth"] else {"lag": 1.5} if smoothing else {}
    out = skidimm.Imm(bank).run(t, u, z, truth=log["mode"], **options)
    expected = tmp_path / "cli.csv"
    cli("run", "--bank", bank_file, "--input", log_file, "--output", expected, "--quiet", *smoothing)
    expected = skidimm.read_csv(expected)
    assert "unknown" in list(expected["mode"])
    total = sum(expected[c] for c in expected if c.startswith("mu_")) + expected["unknown_probability"]
    np.testing.assert_allclose(total, 1.0, atol=1e-12)
    assert_columns_equal(out, expected)


def test_run_log_reads_logs_as_the_cli_does(tmp_path, configs, cli):
    out = skidimm.run_log(configs / "ltc_terrains.yaml", configs / EXAMPLE)
    expected = cli_run(cli, tmp_path, configs)
    assert list(out) == list(expected)
    np.testing.assert_array_equal(out["mu_grass"], expected["mu_grass"])
    assert list(out["truth_mode"]) == list(expected["truth_mode"])


def test_run_log_keeps_the_rows_before_an_error_on_the_exception(tmp_path, configs):
    """A log that goes bad midway (a cell that is not a number, as a recording cut short would): the rows computed
    before it come with the error, as `partial`, equal to a run of the log up to there; nothing is lost."""
    lines = (configs / EXAMPLE).read_text().splitlines()
    header = lines[0].split(",")
    bad = lines[501].split(",")
    bad[header.index("phi_dot_L")] = "oops"
    broken = tmp_path / "broken.csv"
    broken.write_text("\n".join(lines[:501] + [",".join(bad)] + lines[502:]) + "\n")
    head = tmp_path / "head.csv"
    head.write_text("\n".join(lines[:501]) + "\n")
    with pytest.raises(skidimm.LogError, match="broken.csv:502") as raised:
        skidimm.run_log(configs / "ltc_terrains.yaml", broken)
    partial = raised.value.partial
    expected = skidimm.run_log(configs / "ltc_terrains.yaml", head)
    assert len(partial["t"]) == len(expected["t"]) == 500
    for column in expected:
        assert list(partial[column]) == list(expected[column]), column
    # An error before any row carries none.
    with pytest.raises(skidimm.LogError) as nothing:
        skidimm.run_log(configs / "ltc_terrains.yaml", tmp_path / "missing.csv")
    assert not hasattr(nothing.value, "partial")


def test_step_by_step_equals_run(configs):
    bank = skidimm.Bank(configs / "ltc_terrains.yaml")
    _, t, u, z = arrays(configs, bank)
    out = skidimm.Imm(bank).run(t[:200], u[:200], z[:200])
    imm = skidimm.Imm(bank)
    for k in range(200):
        e = imm.step(t[k], u[k], z[k])
        assert e.mode_probabilities.tolist() == [out[f"mu_{m}"][k] for m in bank.modes]
        assert e.state.tolist() == [out["V"][k], out["omega"][k]]
        assert e.mode == out["mode"][k] and e.status == out["status"][k] and e.decision == out["decision"][k]
    assert e.mode_states.shape == (3, 2) and e.mode_covariances.shape == (3, 2, 2)
    # A run in chunks, continuing, equals one run.
    imm.reset()
    first = imm.run(t[:120], u[:120], z[:120])
    rest = imm.run(t[120:200], u[120:200], z[120:200], reset=False)
    np.testing.assert_array_equal(np.concatenate([first["mu_grass"], rest["mu_grass"]]), out["mu_grass"])
    assert list(first["decision"]) + list(rest["decision"]) == list(out["decision"])


def test_missing_measurements_and_rejected_steps(configs):
    imm = skidimm.Imm(configs / "ltc_terrains.yaml")
    t = np.array([0.0, 0.02, 0.02, 0.04, 0.06])
    u = np.ones((5, 2))
    u[3, 0] = np.nan
    z = np.zeros((5, 2))
    z[1] = np.nan
    out = imm.run(t, u, z)
    assert list(out["status"]) == ["updated", "predict_only", "rejected_time", "rejected_input", "updated"]


def test_dataframe_in_dataframe_out(configs):
    pd = pytest.importorskip("pandas")
    bank = skidimm.Bank(configs / "ltc_terrains.yaml")
    frame = pd.DataFrame(skidimm.read_csv(configs / EXAMPLE))
    out = skidimm.Imm(bank).run(frame)
    assert isinstance(out, pd.DataFrame) and len(out) == len(frame)
    assert list(out.columns)[-4:] == ["decision", "truth_mode", "status", "reason"]
    log, t, u, z = arrays(configs, bank)
    np.testing.assert_array_equal(out["mu_grass"].to_numpy(), skidimm.Imm(bank).run(t, u, z)["mu_grass"])
    # Expressions of columns are evaluated like the bank's (muparser).
    assert skidimm.evaluate_expression("abs(a - b) / 2", {"a": np.array([1.0, 4.0]), "b": np.array([3.0, 1.0])}
                                       ).tolist() == [1.0, 1.5]


def test_runs_in_threads_release_the_gil(configs):
    bank = skidimm.Bank(configs / "ltc_terrains.yaml")
    _, t, u, z = arrays(configs, bank)
    t = np.concatenate([t + 40.0 * k for k in range(20)])  # about 30 000 rows
    u, z = np.tile(u, (20, 1)), np.tile(z, (20, 1))
    results = [None, None]

    def work(i):
        results[i] = skidimm.Imm(bank).run(t, u, z)["mu_grass"]

    threads = [threading.Thread(target=work, args=(i,)) for i in range(2)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    np.testing.assert_array_equal(results[0], results[1])


def test_a_rate_unlike_the_banks_is_warned_of_where_its_measurements_aggregate(tmp_path, configs):
    """As ``run --rate`` and ``eval --rate`` warn: over steps of another length, mean() measures something else."""
    text = (configs / "ltc_terrains.yaml").read_text()
    text = text.replace("  time: t\n", '  time: t\n  measurements: {V: "mean(V)", omega: omega}\n', 1)
    text = text.replace("\ncolumns:", "\nsampling: {rate: 20}\ncolumns:", 1)
    assert 'mean(V)' in text
    bank = tmp_path / "averaged.yaml"
    bank.write_text(text)
    log = str(configs / EXAMPLE)
    with pytest.warns(UserWarning, match=r"rate=50 Hz steps bank 'ltc_terrains' at another rate than its "
                                         r"sampling.rate of 20 Hz: columns.measurements.V aggregate"):
        skidimm.run_log(bank, log, rate=50)
    with pytest.warns(UserWarning, match="over steps of 0.02 s they measure something other"):
        skidimm.eval(bank, log, rate=50)
    with pytest.warns(UserWarning, match="confidently wrong"):
        skidimm.evaluate_log(bank, log, rate=50)
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        skidimm.run_log(bank, log, rate=20)
        skidimm.run_log(bank, log)
        skidimm.run_log(configs / "ltc_terrains.yaml", log, rate=50)  # nothing aggregates


def test_run_log_and_eval_warn_of_a_measurement_the_log_left_without_values(configs, tmp_path):
    """As `skidimm run` and `eval` warn: V blank from 5 s to 15 s of the switching example leaves those steps to
    omega alone, which the estimates' status (`updated`) does not show."""
    lines = (configs / "examples" / "ltc_switching.csv").read_text().splitlines()
    header = lines[0].split(",")
    t, v = header.index("t"), header.index("V")
    rows = [lines[0]]
    for line in lines[1:]:
        cells = line.split(",")
        if 5.0 <= float(cells[t]) < 15.0:
            cells[v] = ""
        rows.append(",".join(cells))
    log = tmp_path / "silent_v.csv"
    log.write_text("\n".join(rows) + "\n")
    bank = configs / "ltc_terrains.yaml"
    with pytest.warns(UserWarning, match=r"silent_v\.csv: measurement 'V' .*had no value from t = 5"):
        skidimm.run_log(bank, [str(log)])
    with pytest.warns(UserWarning, match=r"silent_v\.csv: measurement 'V' .*had no value from t = 5"):
        skidimm.eval(bank, [str(log)])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the intact log warns of nothing
        skidimm.run_log(bank, [str(configs / "examples" / "ltc_switching.csv")])
