"""Motion models written in Python, next to compiled plugins."""

import inspect
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import skidimm
from ltc_python import PythonLtc, PythonLtcNumericJacobian


def python_bank(tmp_path, configs, modes=("asphalt", "grass", "crushed_concrete"), model="py_ltc"):
    """configs/ltc_terrains.yaml with the given modes' model replaced by `model`."""
    lines = (configs / "ltc_terrains.yaml").read_text().splitlines()
    out, mode = [], None
    for line in lines:
        if line.strip().startswith("- name:"):
            mode = line.split(":", 1)[1].strip()
        if line.strip() == "model: ltc_linear" and mode in modes:
            line = line.replace("ltc_linear", model)
        out.append(line)
    path = tmp_path / "python_bank.yaml"
    path.write_text("\n".join(out) + "\n")
    return path


def example(configs, bank):
    log = skidimm.read_csv(configs / "examples/ltc_switching.csv")
    return log["t"], np.column_stack([log[c] for c in bank.inputs]), np.column_stack([log[c] for c in bank.measurements])


def test_python_model_gives_the_plugins_probabilities(tmp_path, configs):
    plugin = skidimm.Bank(configs / "ltc_terrains.yaml")
    python = skidimm.Bank(python_bank(tmp_path, configs), models={"py_ltc": PythonLtc})
    assert python.models == ["py_ltc"] * 3
    t, u, z = example(configs, plugin)
    expected = skidimm.Imm(plugin).run(t, u, z)
    out = skidimm.Imm(python).run(t, u, z)
    for m in plugin.modes:
        np.testing.assert_allclose(out[f"mu_{m}"], expected[f"mu_{m}"], rtol=0, atol=1e-12)
    assert list(out["mode"]) == list(expected["mode"])


def test_python_and_compiled_modes_mix_in_one_bank(tmp_path, configs):
    plugin = skidimm.Bank(configs / "ltc_terrains.yaml")
    mixed = skidimm.Bank(python_bank(tmp_path, configs, modes=("grass",)), models={"py_ltc": PythonLtc})
    assert mixed.models == ["ltc_linear", "py_ltc", "ltc_linear"]
    t, u, z = example(configs, plugin)
    expected = skidimm.Imm(plugin).run(t, u, z)
    out = skidimm.Imm(mixed).run(t, u, z)
    np.testing.assert_allclose(out["mu_grass"], expected["mu_grass"], rtol=0, atol=1e-12)


def test_numeric_jacobian_when_none_is_given(tmp_path, configs):
    plugin = skidimm.Bank(configs / "ltc_terrains.yaml")
    python = skidimm.Bank(python_bank(tmp_path, configs), models={"py_ltc": PythonLtcNumericJacobian})
    t, u, z = example(configs, plugin)
    expected = skidimm.Imm(plugin).run(t[:300], u[:300], z[:300])
    out = skidimm.Imm(python).run(t[:300], u[:300], z[:300])
    np.testing.assert_allclose(out["mu_grass"], expected["mu_grass"], atol=1e-6)


def test_registered_models_are_found_by_name(tmp_path, configs):
    skidimm.register_model("py_ltc_registered", PythonLtc)
    bank = skidimm.Bank(python_bank(tmp_path, configs, model="py_ltc_registered"))
    assert bank.models == ["py_ltc_registered"] * 3


class Failing(PythonLtc):
    calls = 0

    def predict(self, x, u, dt):
        Failing.calls += 1
        if Failing.calls > 5:
            raise ZeroDivisionError("the model's own error")
        return super().predict(x, u, dt)


def test_an_exception_in_predict_comes_back_as_itself(tmp_path, configs):
    bank = skidimm.Bank(python_bank(tmp_path, configs), models={"py_ltc": Failing})
    t, u, z = example(configs, bank)
    with pytest.raises(ZeroDivisionError, match="the model's own error"):
        skidimm.Imm(bank).run(t, u, z)
    calls = Failing.calls
    assert calls < 20  # the engine stopped calling Python after the first exception
    Failing.calls = -10**9
    assert skidimm.Imm(bank).step(0.0, u[0], z[0]).status == "updated"  # the interpreter and the bank live on


class TurnsNaN(PythonLtc):
    def predict(self, x, u, dt):
        return np.full(2, np.nan) if u[0] > 1.0 else super().predict(x, u, dt)


def test_a_step_says_which_mode_failed_and_why(tmp_path, configs):
    bank = skidimm.Bank(python_bank(tmp_path, configs, modes=("grass",)), models={"py_ltc": TurnsNaN})
    t, u, z = example(configs, bank)
    imm = skidimm.Imm(bank)
    first = imm.step(t[0], np.zeros(2), z[0])
    assert first.mode_failures == ["", "", ""]
    imm.step(t[1], np.array([2.0, 2.0]), z[1])  # held into the next step's prediction
    failed = imm.step(t[2], np.zeros(2), z[2])
    assert failed.num_rejected_modes == 1
    assert failed.mode_failures[0] == "" and failed.mode_failures[2] == ""
    assert failed.mode_failures[1].startswith("the model returned a non-finite state")


def test_bad_python_models_are_config_errors(tmp_path, configs):
    class NoPredict(skidimm.MotionModel):
        pass

    class WrongStates(PythonLtc):
        states = ("omega", "V")

    path = python_bank(tmp_path, configs)
    with pytest.raises(skidimm.ConfigError, match="defines no predict") as caught:
        skidimm.Bank(path, models={"py_ltc": NoPredict})
    assert caught.value.field == "modes[0].model"
    with pytest.raises(skidimm.ConfigError, match=r"has states \[omega, V\] but the bank declares \[V, omega\]"):
        skidimm.Bank(path, models={"py_ltc": WrongStates})
    bad = path.read_text().replace("params: {A:", "params: {C: 1, A:", 1)
    path.write_text(bad)
    with pytest.raises(skidimm.ConfigError, match="expected the parameters A and B") as caught:
        skidimm.Bank(path, models={"py_ltc": PythonLtc})
    assert caught.value.field == "modes[0].params" and caught.value.line > 0
    with pytest.raises(TypeError):
        skidimm.Bank(path, models={"py_ltc": object})


def test_python_models_can_be_fitted(tmp_path, configs, singular_logs):
    logs = [f"asphalt={p}" for p in singular_logs["asphalt"]]
    compiled = skidimm.fit(configs / "ltc_terrains.yaml", logs, objective="window", window=0.5)
    python = skidimm.fit(python_bank(tmp_path, configs), logs, objective="window", window=0.5,
                         models={"py_ltc": PythonLtc})
    a = compiled["reports"]["asphalt"]["parameters"]
    b = python["reports"]["asphalt"]["parameters"]
    assert a.keys() == b.keys()
    for name in a:
        assert b[name][0] == pytest.approx(a[name][0], rel=1e-4, abs=1e-6), name


def test_fit_shows_its_progress_on_a_terminal_only(tmp_path, configs, singular_logs):
    """A fit of a Python model can take minutes: on a terminal stderr shows the mode and the
    solver's iterations as they go; through a pipe (a script's log) nothing of it."""
    bank = python_bank(tmp_path, configs)
    logs = [f"asphalt={p}" for p in singular_logs["asphalt"]]
    script = (f"import sys; sys.path.insert(0, {str(pathlib.Path(__file__).parent)!r})\n"
              "import skidimm\nfrom ltc_python import PythonLtc\n"
              f"skidimm.fit({str(bank)!r}, {logs!r}, objective='window', window=0.5, models={{'py_ltc': PythonLtc}})\n")
    piped = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True)
    assert "skidimm.fit:" not in piped.stderr and "\r" not in piped.stderr, piped.stderr

    controller, terminal = os.openpty()
    with subprocess.Popen([sys.executable, "-c", script], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                          stderr=terminal) as child:
        os.close(terminal)
        seen = b""
        while True:
            try:
                chunk = os.read(controller, 4096)
            except OSError:  # EIO: every end of the terminal closed
                break
            if not chunk:
                break
            seen += chunk
        assert child.wait() == 0, seen
    os.close(controller)
    text = seen.decode(errors="replace")
    # The first iteration at once; its rate only after a second (format_rate_and_time_left).
    assert "\rskidimm.fit: mode 'asphalt' (window objective)  1 iterations" in text, text
    assert text.endswith("\r\x1b[K"), "the line is cleared when the fit ends"


def test_python_models_are_built_and_checked_by_the_library_bank_builder(tmp_path, configs):
    """One bank builder for plugins and Python models: the same checks, the same record of sources."""
    path = python_bank(tmp_path, configs, modes=("grass",))
    bank = skidimm.Bank(path, models={"py_ltc": PythonLtc})
    sources = bank.model_sources
    assert sources[0].startswith("plugin ltc_linear ") and sources[0].endswith("skidimm_ltc_linear.so)")
    assert sources[1] == f"Python model py_ltc ({inspect.getfile(PythonLtc)})"
    # A measured output the model does not give is refused, as for a plugin's model.
    text = path.read_text().replace("  observe: [V, omega]", "  observe: [V, omega]\n  outputs: [slip]", 1)
    text = text.replace("R: {std: [0.05, 0.02]}", "R: {std: [0.05, 0.02, 0.1]}", 1)
    path.write_text(text.replace("model: ltc_linear", "model: py_ltc"))
    with pytest.raises(skidimm.ConfigError, match=r"mode 'asphalt' \(model py_ltc\) has no output 'slip'") as caught:
        skidimm.Bank(path, models={"py_ltc": PythonLtc})
    assert caught.value.field == "modes[0].model"
