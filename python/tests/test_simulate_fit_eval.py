"""simulate, fit and eval as functions, against the CLI's output."""

import json

import numpy as np
import pytest

import skidimm
from faulty_logs import a_row_written_twice


def test_simulate_equals_the_cli(tmp_path, configs, cli):
    scenario = configs / "scenarios" / "ltc_switching.yaml"
    out = skidimm.simulate(scenario, seed=11, duration=5.0)
    cli("simulate", "--scenario", scenario, "--seed", 11, "--duration", 5, "--output", tmp_path / "cli.csv", "--quiet")
    expected = skidimm.read_csv(tmp_path / "cli.csv")
    assert list(out) == list(expected)
    for name, column in expected.items():
        if column.dtype == object:
            assert list(out[name]) == list(column)
        else:
            np.testing.assert_array_equal(out[name], column, err_msg=name)


def test_simulate_models(tmp_path, configs):
    out = skidimm.simulate_models(configs / "ltc_terrains.yaml", str(configs / "examples/ltc_switching.csv"), seed=3)
    assert {"t", "phi_dot_L", "V", "omega", "mode", "true_V"} <= set(out)
    assert set(out["mode"]) == {"asphalt", "grass", "crushed_concrete"}


def test_eval_equals_the_cli_json(configs, cli, switching_logs):
    bank = configs / "ltc_terrains.yaml"
    first = switching_logs / "run_00.csv"
    arguments = [str(first), f"grass={switching_logs / 'run_01.csv'}"]
    text = skidimm.eval(bank, arguments, output="json")
    assert text == cli("eval", "--bank", bank, "--input", arguments[0], "--input", arguments[1], "--json")
    report = skidimm.eval(bank, arguments)
    assert report == json.loads(text)
    assert set(report["groups"]) == {"run_00", "grass"}
    table = skidimm.eval(bank, arguments, output="table")
    assert table == cli("eval", "--bank", bank, "--input", arguments[0], "--input", arguments[1])


def test_eval_range_for_equals_the_cli_json(configs, cli, switching_logs):
    """``range_for`` is ``--range-for``: the range another set of that many logs per class would score."""
    bank = configs / "ltc_terrains.yaml"
    own = skidimm.eval(bank, [switching_logs])["overall"]["mean_over_classes"]["range"]
    assert sum(own["logs_per_class"].values()) == 24 and own["level"] == 0.9
    assert own["low"] <= skidimm.eval(bank, [switching_logs])["overall"]["mean_over_classes"]["accuracy"] <= own["high"]
    doubled = {name: 2 * count for name, count in own["logs_per_class"].items()}
    text = skidimm.eval(bank, [switching_logs], range_for=doubled, output="json")
    counts = ",".join(f"{name}={count}" for name, count in doubled.items())
    assert text == cli("eval", "--bank", bank, "--input", switching_logs, "--range-for", counts, "--json")
    assert json.loads(text)["overall"]["mean_over_classes"]["range"]["logs_per_class"] == doubled
    # A class no log was scored for (each of these runs is mostly crushed concrete): every figure kept, the
    # problem in the range's place, and a warning.
    with pytest.warns(UserWarning, match="range_for: class 'grass' of the other set has no scored log here"):
        report = skidimm.eval(bank, [switching_logs], range_for={**doubled, "grass": 3})
    assert "problem" in report["overall"]["mean_over_classes"]["range"]
    assert report["overall"]["accuracy"] is not None
    for bad in ({"grass": 0}, {"grass": 2.5}, {"grass": True}, {"grass": 10**8}, {" grass": 2}, {}, "grass=2"):
        with pytest.raises(ValueError, match="range_for"):
            skidimm.eval(bank, [switching_logs / "no_such_run.csv"], range_for=bad)  # refused before any log is read


def test_eval_splice_equals_the_cli_json(configs, cli, switching_logs):
    """``splice=True`` is ``--splice``: the logs as one run, the groups taking turns."""
    bank = configs / "ltc_terrains.yaml"
    arguments = [f"asphalt={switching_logs / 'run_03.csv'}", f"grass={switching_logs / 'run_04.csv'}",
                 str(switching_logs / "run_05.csv")]
    text = skidimm.eval(bank, arguments, splice=True, output="json")
    flags = [part for argument in arguments for part in ("--input", argument)]
    assert text == cli("eval", "--bank", bank, "--splice", *flags, "--json")
    report = json.loads(text)
    assert list(report["groups"]) == ["spliced (3 logs end to end, the groups taking turns)"]
    switches = next(iter(report["logs"].values()))["switches"]
    assert [(s["from"], s["to"]) for s in switches[:2]] == [("asphalt", "grass"), ("grass", "crushed_concrete")]
    with pytest.raises(ValueError, match="splice scores the filter as it runs across each change"):
        skidimm.eval(bank, arguments, splice=True, smooth=True)


def test_eval_splice_warns_of_a_measurement_a_log_never_gave(configs, switching_logs, tmp_path):
    log = skidimm.read_csv(switching_logs / "run_04.csv")
    columns = [c for c in log if c not in ("mode",)]
    no_gyro = tmp_path / "no_gyro.csv"
    with open(no_gyro, "w") as f:
        f.write(",".join(columns + ["mode"]) + "\n")
        for k in range(len(log["t"])):
            cells = ["" if c == "omega" else repr(float(log[c][k])) for c in columns]
            f.write(",".join(cells + [log["mode"][k]]) + "\n")
    with pytest.warns(UserWarning, match=f"^{no_gyro}: measurement 'omega'"):
        skidimm.eval(configs / "ltc_terrains.yaml", [str(switching_logs / "run_03.csv"), str(no_gyro)], splice=True)


def test_a_log_result_says_what_the_banks_options_left_out(configs, switching_logs, tmp_path):
    twice, bank = a_row_written_twice(configs, switching_logs, tmp_path)
    result = skidimm.evaluate_log(bank, str(twice))
    assert len(result.skipped) == 1
    assert result.skipped[0].startswith("1 row(s) whose time was not after their file's last row were left out "
                                        f"(sampling.skip_out_of_order), the first at {twice}:302: t = ")
    assert skidimm.evaluate_log(configs / "ltc_terrains.yaml", str(switching_logs / "run_02.csv")).skipped == []
    import pickle
    assert pickle.loads(pickle.dumps(result)).skipped == result.skipped


def test_fit_warns_of_what_the_banks_options_left_out_as_the_cli_says_it(configs, switching_logs, tmp_path):
    twice, bank = a_row_written_twice(configs, switching_logs, tmp_path)
    said = (f"{twice}: 1 row(s) whose time was not after their file's last row were left out "
            f"(sampling.skip_out_of_order), the first at {twice}:302: t = ")
    with pytest.warns(UserWarning) as warned:
        skidimm.fit(bank, [str(twice)], objective="window")
    # The words of `skidimm fit: ...` on stderr (tests/cli/hostile_input_test.cc).
    assert [str(w.message) for w in warned if str(w.message).startswith(said)], [str(w.message) for w in warned]
    # A log with nothing left out: no such warning.
    import warnings
    with warnings.catch_warnings(record=True) as quiet:
        warnings.simplefilter("always")
        skidimm.fit(bank, [str(switching_logs / "run_02.csv")], objective="window")
    assert not [w for w in quiet if "left out" in str(w.message)]


def test_log_results_pickle_losslessly(configs, switching_logs):
    import pickle

    result = skidimm.evaluate_log(configs / "ltc_terrains.yaml", str(switching_logs / "run_02.csv"), smooth=True)
    back = pickle.loads(pickle.dumps(result))
    assert back.to_dict() == result.to_dict()
    assert result.accuracy > 0.5 and result.steps > 100


def body(text):
    """A written bank but its leading comment (which records the command)."""
    lines = text.splitlines()
    while lines and lines[0].startswith("#"):
        lines.pop(0)
    return lines


def test_fit_equals_the_cli(tmp_path, configs, cli, singular_logs):
    bank = configs / "ltc_terrains.yaml"
    logs = [f"asphalt={p}" for p in singular_logs["asphalt"]] + [f"grass={p}" for p in singular_logs["grass"]]
    result = skidimm.fit(bank, logs, objective="window", window=0.5, output_bank=tmp_path / "python.yaml")
    arguments = ["fit", "--bank", bank, "--objective", "window", "--window", 0.5, "--output-bank", tmp_path / "cli.yaml"]
    for log in logs:
        arguments += ["--log", log]
    cli(*arguments)

    assert body(result["bank_yaml"]) == body((tmp_path / "cli.yaml").read_text())
    assert (tmp_path / "python.yaml").read_text() == result["bank_yaml"]
    assert set(result["reports"]) == {"asphalt", "grass"}
    report = result["reports"]["asphalt"]
    assert report["rmse"].shape == (2,) and report["q"].shape == (2, 2)
    value, sd = report["parameters"]["A[0,0]"]
    assert value < 0 and sd > 0
    assert "- name: asphalt" in result["entries"]
    fitted = result["bank"]
    assert fitted.parameters("asphalt")["A[0,0]"] == pytest.approx(value, rel=1e-6)
    skidimm.Imm(fitted).step(0.0, [1.0, 1.0], [0.1, 0.0])


def test_fit_writes_parameter_uncertainty_and_residual_correlation_as_the_cli_does(tmp_path, configs, cli,
                                                                                    singular_logs):
    """parameter_uncertainty, uncertainty_per_log and residual_correlation are fit's --parameter-uncertainty,
    --uncertainty-per-log and --residual-correlation (the CLI's advice named them; Python had none of them)."""
    bank = configs / "ltc_terrains.yaml"
    logs = [f"asphalt={p}" for p in singular_logs["asphalt"]] + [f"grass={p}" for p in singular_logs["grass"]]
    result = skidimm.fit(bank, logs, objective="window", parameter_uncertainty=True, uncertainty_per_log=True,
                         residual_correlation=True)
    arguments = ["fit", "--bank", bank, "--objective", "window", "--parameter-uncertainty", "--uncertainty-per-log",
                 "--residual-correlation", "--output-bank", tmp_path / "cli.yaml"]
    for log in logs:
        arguments += ["--log", log]
    cli(*arguments)
    assert "parameter_covariance" in result["bank_yaml"] and "residual_correlation" in result["bank_yaml"]
    assert body(result["bank_yaml"]) == body((tmp_path / "cli.yaml").read_text())
    with pytest.raises(skidimm.Error, match="uncertainty_per_log scales each mode's parameter covariance"):
        skidimm.fit(bank, logs, objective="window", uncertainty_per_log=True)
    with pytest.raises(skidimm.Error, match="parameter_uncertainty is an option of the window objective"):
        skidimm.fit(bank, logs, parameter_uncertainty=True)


def test_fit_at_a_rate_writes_it_as_the_banks_as_the_cli_does(tmp_path, configs, cli, singular_logs):
    bank = configs / "ltc_terrains.yaml"
    logs = [f"asphalt={p}" for p in singular_logs["asphalt"]]
    result = skidimm.fit(bank, logs, objective="window", window=0.5, rate=20)
    arguments = ["fit", "--bank", bank, "--objective", "window", "--window", 0.5, "--rate", 20,
                 "--output-bank", tmp_path / "cli.yaml"]
    for log in logs:
        arguments += ["--log", log]
    cli(*arguments)
    assert body(result["bank_yaml"]) == body((tmp_path / "cli.yaml").read_text())
    assert "sampling:\n  rate: 20\n" in result["bank_yaml"]
    assert "sampling:" not in skidimm.fit(bank, logs, objective="window", window=0.5)["bank_yaml"]


def test_fit_checks_its_output_bank_before_fitting(tmp_path, configs, singular_logs, monkeypatch):
    bank = configs / "ltc_terrains.yaml"
    logs = [f"asphalt={p}" for p in singular_logs["asphalt"]]
    missing = tmp_path / "no_such_directory" / "fitted.yaml"
    # The check comes first: a fit that started would be an error of its own.
    monkeypatch.setattr(skidimm._native, "fit_in_place", lambda *a: pytest.fail("fitted before the check"))
    with pytest.raises(skidimm.Error,
                       match="output_bank .*no_such_directory/fitted.yaml: cannot write there: No such file"):
        skidimm.fit(bank, logs, objective="window", output_bank=missing)
    with pytest.raises(skidimm.Error, match="is a directory"):
        skidimm.fit(bank, logs, objective="window", output_bank=tmp_path)
    assert not missing.parent.exists()
    # A mode its class lists by name, renamed in the bank every fit writes, would make it invalid: said first.
    classed = tmp_path / "classed.yaml"
    classed.write_text(bank.read_text() + "\nclasses:\n  paved: [asphalt, crushed_concrete]\n  soft: [grass]\n")
    with pytest.raises(skidimm.ConfigError, match=r"name='tarmac': the written bank would rename mode 'asphalt' "
                                                  r"to 'tarmac', and class paved of .*classed.yaml lists it"):
        skidimm.fit(classed, logs, mode="asphalt", name="tarmac", objective="window")


@pytest.fixture(scope="module")
def traction_logs(tmp_path_factory, configs):
    """Two short realistic runs with right-two slip: the gyro and the motor currents as outputs."""
    directory = tmp_path_factory.mktemp("traction")
    scenario = configs / "scenarios" / "realistic" / "stc_singular_slip_FR_RR.yaml"
    paths = []
    for seed in (11, 12):
        path = directory / f"slip_FR_RR_{seed}.csv"
        skidimm.simulate(scenario, seed=seed, duration=12.0, output=path)
        paths.append(f"slip_FR_RR={path}")
    return paths


def test_fit_with_each_modes_own_output_noise_equals_the_cli(tmp_path, configs, cli, traction_logs):
    bank = configs / "realistic" / "stc_traction4.yaml"
    options = dict(objective="window", window=1.0, hold_unexcited=True)
    own = skidimm.fit(bank, traction_logs, output_noise=True, **options)
    arguments = ["fit", "--bank", bank, "--objective", "window", "--window", 1.0, "--hold-unexcited", "--output-noise",
                 "--output-bank", tmp_path / "cli.yaml"]
    for log in traction_logs:
        arguments += ["--log", log]
    cli(*arguments)

    assert body(own["bank_yaml"]) == body((tmp_path / "cli.yaml").read_text())
    # Without it the mode keeps the R it had; with it, its outputs' rows are
    # its residuals' on these logs.
    kept = skidimm.fit(bank, traction_logs, **options)

    def entry(result):
        return result["entries"].split("- name: ")[1]

    assert "R:" in entry(own) and "R:" in entry(kept)
    assert entry(own) != entry(kept)


def test_eval_keys_logs_by_path_and_pairs_patterns_by_run_key(tmp_path, configs, switching_logs):
    import csv
    import shutil

    bank = configs / "ltc_terrains.yaml"
    for directory in ("a", "b"):
        (tmp_path / directory).mkdir()
        shutil.copy(switching_logs / "run_00.csv", tmp_path / directory / "run.csv")
    report = skidimm.eval(bank, [tmp_path / "a", tmp_path / "b"])
    assert set(report["logs"]) == {str(tmp_path / "a" / "run.csv"), str(tmp_path / "b" / "run.csv")}

    # One run split into a wheel file and a sensor file, and a wheel file without its partner.
    with open(switching_logs / "run_00.csv") as f:
        rows = list(csv.DictReader(f))
    split = tmp_path / "split"
    split.mkdir()
    for name, columns in (("pro_01", ["t", "phi_dot_L", "phi_dot_R", "mode"]), ("imu_01", ["t", "V", "omega"]),
                          ("pro_02", ["t", "phi_dot_L", "phi_dot_R", "mode"])):
        with open(split / f"{name}.csv", "w", newline="") as f:
            writer = csv.DictWriter(f, columns, extrasaction="ignore")
            writer.writeheader()
            writer.writerows(rows)
    pattern = f"{split / 'pro_*.csv'}+{split / 'imu_*.csv'}"
    with pytest.raises(skidimm.Error, match=r"pro_02\.csv has no partner .*imu_02\.csv"):
        skidimm.eval(bank, [pattern])
    with pytest.warns(UserWarning, match=r"left out: .*pro_02\.csv"):
        report = skidimm.eval(bank, [pattern], skip_unpaired=True)
    assert report["overall"]["logs"] == 1
    assert list(report["logs"]) == [f"{split / 'pro_01.csv'}+{split / 'imu_01.csv'}"]


@pytest.mark.parametrize("option", [{"window": 1.0}, {"loss": "cauchy"}, {"loss_scale": 5.0}, {"output_noise": True}])
def test_fit_refuses_the_window_objectives_options_under_the_likelihood(configs, singular_logs, option):
    """As ``skidimm fit`` refuses them (exit 2): under the default objective they would be ignored."""
    logs = [f"asphalt={p}" for p in singular_logs["asphalt"]]
    name = next(iter(option))
    with pytest.raises(skidimm.Error, match=f"^{name} is an option of the window objective; add objective=\"window\""):
        skidimm.fit(configs / "ltc_terrains.yaml", logs, **option)


def test_fit_refuses_fit_r_under_the_window_objective(configs, singular_logs):
    logs = [f"asphalt={p}" for p in singular_logs["asphalt"]]
    with pytest.raises(skidimm.Error, match="fit_r is an option of the likelihood objective"):
        skidimm.fit(configs / "ltc_terrains.yaml", logs, objective="window", fit_r=True)


def test_eval_tells_groups_named_alike_apart_as_the_cli(tmp_path, configs, cli, switching_logs):
    """Two folders' '*' patterns of one folder name are two groups, named as the CLI names them (a dict kept one)."""
    bank = configs / "ltc_terrains.yaml"
    for parent in ("x", "y"):
        (tmp_path / parent / "runs").mkdir(parents=True)
        (tmp_path / parent / "runs" / "a.csv").write_text((switching_logs / "run_00.csv").read_text())
    arguments = [str(tmp_path / "x" / "runs" / "*.csv"), str(tmp_path / "y" / "runs" / "*.csv")]
    report = skidimm.eval(bank, arguments)
    assert len(report["groups"]) == 2
    expected = json.loads(cli("eval", "--bank", bank, "--input", arguments[0], "--input", arguments[1], "--json"))
    assert list(report["groups"]) == list(expected["groups"])
    assert skidimm.eval(bank, arguments, output="json") == cli("eval", "--bank", bank, "--input", arguments[0],
                                                               "--input", arguments[1], "--json")
