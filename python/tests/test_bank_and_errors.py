"""Loading banks, finding plugins without configuration, and errors as Python exceptions."""

import os
import pathlib

import numpy as np
import pytest

import skidimm


def test_bundled_plugins_are_found_next_to_the_module(configs):
    directory = pathlib.Path(skidimm.module_plugin_directory())
    assert directory.is_dir()
    assert directory.parts[-2:] == ("skidimm", "plugins")
    names = {p["name"] for p in skidimm.plugins() if not p["error"]}
    assert {"ltc_linear", "ltc_shared", "stc_kinematic", "stc_sided", "linear_features"} <= names
    # No plugin_paths, no $SKIDIMM_PLUGIN_PATH: the bank loads all the same.
    bank = skidimm.Bank(configs / "stc_slip4.yaml")
    assert bank.models == ["stc_kinematic"] * 4


def test_search_path_order_is_the_clis(tmp_path, monkeypatch):
    monkeypatch.setenv("SKIDIMM_PLUGIN_PATH", str(tmp_path / "env"))
    path = [pathlib.Path(p) for p in skidimm.plugin_search_path([str(tmp_path / "explicit")], [str(tmp_path / "bank")])]
    here = pathlib.Path(skidimm.module_plugin_directory())
    assert path[:4] == [tmp_path / "explicit", tmp_path / "bank", tmp_path / "env", here]


def test_bank_properties(configs):
    bank = skidimm.Bank(configs / "ltc_terrains.yaml")
    assert bank.name == "ltc_terrains"
    assert bank.states == ["V", "omega"] and bank.inputs == ["phi_dot_L", "phi_dot_R"]
    assert bank.measurements == ["V", "omega"]
    assert bank.modes == ["asphalt", "grass", "crushed_concrete"]
    assert bank.columns["truth_mode"] == "mode"
    assert bank.parameters("asphalt")["A[0,0]"] == pytest.approx(-36.28555)
    with pytest.raises(KeyError):
        bank.parameters("ice")


def write_bank(tmp_path, text):
    path = tmp_path / "bank.yaml"
    path.write_text(text)
    return path


BROKEN = """name: broken
states: [V, omega]
inputs: [phi_dot_L, phi_dot_R]
measurement:
  observe: [V, omega]
  R: {std: [0.05, 0.02]}
transition: {mean_dwell_time: 10.0}
initial:
  covariance: {std: [0.5, 0.5]}
modes:
  - name: asphalt
    model: ltc_linear
    params: {A: [[-5, 0], [0, -4]], B: [[0.39, 0.39], [-0.83, 0.83]]}
    Q: [[0.01, 0, 0], [0, 0.01, 0]]
"""


def test_config_error_is_a_value_error_with_file_line_and_field(tmp_path, cli):
    path = write_bank(tmp_path, BROKEN)
    with pytest.raises(skidimm.ConfigError) as caught:
        skidimm.Bank(path)
    error = caught.value
    assert isinstance(error, ValueError) and isinstance(error, skidimm.Error)
    assert error.file == str(path) and error.line == 14 and error.field == "modes[0].Q"
    # The same message as the CLI's.
    import subprocess

    executable = os.environ.get("SKIDIMM_EXECUTABLE")
    if executable:
        result = subprocess.run([executable, "validate", str(path)], capture_output=True, text=True)
        assert result.returncode == 1
        assert str(error) in result.stderr


def test_unknown_plugin_is_a_config_error_naming_the_search_path(tmp_path):
    path = write_bank(tmp_path, BROKEN.replace("ltc_linear", "no_such_model").replace(
        "[[0.01, 0, 0], [0, 0.01, 0]]", "{diagonal: [0.01, 0.01]}"))
    with pytest.raises(skidimm.ConfigError, match="no plugin named 'no_such_model'") as caught:
        skidimm.Bank(path)
    assert caught.value.field == "modes[0].model"


def test_log_error_names_file_and_line(tmp_path, configs):
    log = tmp_path / "bad.csv"
    log.write_text("t,phi_dot_L,phi_dot_R,V,omega,mode\n0,1,1,0.1,0,asphalt\n0.02,1,oops,0.1,0,asphalt\n")
    with pytest.raises(skidimm.LogError) as caught:
        skidimm.run_log(configs / "ltc_terrains.yaml", log)
    assert isinstance(caught.value, ValueError)
    assert caught.value.file == str(log) and caught.value.line == 3


def test_wrong_array_shapes_raise_instead_of_aborting(configs):
    imm = skidimm.Imm(configs / "ltc_terrains.yaml")
    with pytest.raises(ValueError, match="u: expected shape"):
        imm.step(0.0, [1.0, 2.0, 3.0], [0.0, 0.0])
    with pytest.raises(ValueError, match="z: expected shape"):
        imm.run(np.arange(3.0), np.zeros((3, 2)), np.zeros((2, 2)))
    assert imm.step(0.0, [1.0, 1.0], [0.0, 0.0]).status == "updated"  # still usable


def test_an_infinite_measurement_is_refused_not_taken_as_missing(configs):
    # NaN is "not measured"; inf is a bad value, as the CLI's reader says of a cell.
    imm = skidimm.Imm(configs / "ltc_terrains.yaml")
    z = np.zeros((4, 2))
    z[2, 1] = -np.inf
    with pytest.raises(ValueError, match=r"z\[2, 1\] is -inf: a measurement is a finite number, or NaN"):
        imm.run(np.arange(4.0), np.ones((4, 2)), z)
    with pytest.raises(ValueError, match=r"z\[0, 0\] is inf"):
        imm.step(0.0, [1.0, 1.0], [np.inf, 0.0])
    z[2, 1] = np.nan
    assert list(imm.run(np.arange(4.0), np.ones((4, 2)), z)["status"])[2] == "updated"  # NaN: one row not measured


def test_fit_error(tmp_path, configs, singular_logs):
    short = tmp_path / "short.csv"
    lines = pathlib.Path(singular_logs["asphalt"][0]).read_text().splitlines()[:4]
    short.write_text("\n".join(lines) + "\n")
    with pytest.raises(skidimm.FitError):
        skidimm.fit(configs / "ltc_terrains.yaml", [f"asphalt={short}"], objective="window", window=0.5)


def test_bad_decision_settings_are_an_error_naming_the_values(configs):
    bank = configs / "ltc_terrains.yaml"
    with pytest.raises(skidimm.Error, match=r"need 0 <= leave < enter <= 1, got enter 0\.3, leave 0\.4"):
        skidimm.Imm(bank, decision={"enter": 0.3, "leave": 0.4})
    with pytest.raises(skidimm.Error, match=r"need min_hold >= 0 s and under 1e9 s, got -1"):
        skidimm.Imm(bank, decision={"min_hold": -1.0})
    with pytest.raises(KeyError, match=r"unknown key 'hold' \(expected enter, leave, min_hold, stale_after\)"):
        skidimm.Imm(bank, decision={"hold": 1.0})
    assert skidimm.Imm(bank, decision={"enter": 0.6}).step(0.0, [1.0, 1.0], [0.1, 0.0]).decision == "unknown"


def test_times_that_are_not_seconds_are_refused_with_the_conversion(configs, tmp_path):
    """Datetimes, and numbers beyond 1e11 s (ns, us or ms since 1970), read as seconds made every step a gap of
    years and a run of wrong estimates without an error."""
    import pandas as pd

    imm = skidimm.Imm(configs / "ltc_terrains.yaml")
    t = np.arange(0.0, 5.0, 0.1) + 1.7e9
    u, z = np.ones((len(t), 2)), np.zeros((len(t), 2))
    assert list(imm.run(t, u, z)["status"][:2]) == ["updated", "updated"]  # seconds since 1970 are seconds
    with pytest.raises(ValueError, match=r"t\[0\] = 1\.7e\+18: over 3000 years, no time in seconds"):
        imm.run((t * 1e9).astype(np.int64), u, z)
    with pytest.raises(ValueError, match=r"t steps by 1e\+08 s at the median, over an hour"):
        imm.run(np.arange(len(t)) * 1e8, u, z)  # ns from the log's start, a row every 0.1 s
    imm.reset()
    with pytest.raises(ValueError, match=r"t = 1\.7e\+12: over 3000 years"):
        imm.step(1.7e12, [1.0, 1.0], [0.0, 0.0])  # the first step shows the unit
    imm.step(1.0, [1.0, 1.0], [0.0, 0.0])
    assert imm.step(1e308, [1.0, 1.0], [0.0, 0.0]).status != "updated"  # later, one bad time is the engine's to ignore
    imm.reset()
    imm.step(float("nan"), [1.0, 1.0], [0.0, 0.0])  # a NaN first step shows no unit: the next is still checked
    with pytest.raises(ValueError, match=r"t = 1\.7e\+18: over 3000 years"):
        imm.step(1.7e18, [1.0, 1.0], [0.0, 0.0])
    # Milliseconds from the start: steps of 20 "s", each longer than the bank's sampling.max_gap (10 s) over which
    # the log reader takes no step, refused as the CLI refuses such a file's first gap; a bank that allows them
    # runs them.
    imm.reset()
    with pytest.raises(ValueError, match=r"t steps by 20 s at the median, longer than the bank's sampling\.max_gap "
                                         r"\(10 s\).*are the times in seconds \(milliseconds from the start"):
        imm.run(np.arange(len(t)) * 20.0, u, z)
    slow = tmp_path / "slow.yaml"
    slow.write_text((configs / "ltc_terrains.yaml").read_text() + "sampling: {max_gap: 30}\n")
    assert len(skidimm.Imm(slow).run(np.arange(len(t)) * 20.0, u, z)["t"]) == len(t)
    # A pause is no unit: three steps at least, their lower median.
    assert len(imm.run(np.array([0.0, 0.1, 4000.0]), np.ones((3, 2)), np.zeros((3, 2)))["t"]) == 3
    assert len(imm.run(np.array([0.0, 0.1, 0.2, 4000.0, 8000.0]), np.ones((5, 2)), np.zeros((5, 2)))["t"]) == 5
    with pytest.raises(ValueError, match=r"t: datetime values; .*np\.timedelta64\(1, 's'\)"):
        imm.run(pd.to_datetime(t, unit="s").values, u, z)
    frame = pd.DataFrame({"t": pd.to_datetime(t, unit="s"), "phi_dot_L": 1.0, "phi_dot_R": 1.0, "V": 0.0, "omega": 0.0})
    with pytest.raises(ValueError, match="datetime values"):
        imm.run(frame)


def test_a_frame_of_a_bank_with_a_time_unit_is_read_in_seconds(configs, tmp_path):
    """columns.time_unit: a DataFrame's time column is read in the bank's unit, as run_log and the CLI read it."""
    import pandas as pd

    ms_bank = tmp_path / "ms.yaml"
    ms_bank.write_text((configs / "ltc_terrains.yaml").read_text().replace("  time: t\n", "  time: t\n  time_unit: ms\n"))
    frame = pd.read_csv(configs / "examples" / "ltc_switching.csv")
    in_seconds = skidimm.Imm(configs / "ltc_terrains.yaml").run(frame)
    frame["t"] = frame["t"] * 1000.0
    in_ms = skidimm.Imm(ms_bank).run(frame)
    assert np.allclose(in_ms["t"], in_seconds["t"], rtol=1e-12, atol=0)
    assert (in_ms["mode"] == in_seconds["mode"]).mean() > 0.99
    assert skidimm.Bank(ms_bank).columns["time_units_per_second"] == 1000.0


def test_the_decision_goes_stale_after_the_seconds_given(configs):
    """``decision={"stale_after": s}`` as ``--decision-stale-after``: with every measurement missing (NaN) for
    longer, the decision is given up for unknown; 0: never; negative: an error naming the value."""
    bank = configs / "ltc_terrains.yaml"
    t = np.arange(0.0, 20.0, 0.1)
    u = np.ones((len(t), 2))
    z = np.tile([0.1, 0.0], (len(t), 1))
    z[t >= 5.0] = np.nan
    silent = t >= 5.0

    def decisions(decision):
        return np.array(list(skidimm.run(bank, t, u, z, decision=dict(decision, enter=0.3))["decision"]))

    assert skidimm.Bank(bank).decision["stale_after"] == 10.0  # unset: the bank's shortest mean dwell time
    taken = decisions({})[t < 5.0]
    assert taken[-1] != "unknown"
    three = decisions({"stale_after": 3.0})
    assert (three[silent & (t >= 7.95)] == "unknown").all()  # 3 s after the last measured step, at 4.9 s
    assert (three[silent & (t < 7.85)] == taken[-1]).all()
    assert (decisions({"stale_after": 0.0})[silent] == taken[-1]).all()
    with pytest.raises(skidimm.Error, match=r"stale_after: need seconds >= 0 \(0: never\) and under 1e9, got -2"):
        skidimm.Imm(bank, decision={"stale_after": -2.0})


def test_a_plugin_path_that_does_not_exist_is_an_error(configs, tmp_path):
    """As ``--plugin-path`` refuses it: a misspelt directory would search nothing, without a word."""
    missing = tmp_path / "no_such_directory"
    with pytest.raises(skidimm.Error, match=r"plugin_paths: '.*no_such_directory': no such directory or plugin file"):
        skidimm.Bank(configs / "ltc_terrains.yaml", plugin_paths=[missing])
    assert skidimm.Bank(configs / "ltc_terrains.yaml", plugin_paths=[tmp_path]).modes
    with pytest.raises(skidimm.Error, match="no such directory or plugin file"):
        skidimm.plugins([missing])
