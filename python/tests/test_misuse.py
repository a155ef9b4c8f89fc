"""What a careless or hostile caller can do from Python ends in a clear
exception or a correct result: never NaN probabilities handed back silently,
never a crash of the interpreter."""

import threading

import numpy as np
import pytest

import skidimm
from example_log import arrays
from ltc_python import PythonLtc


def test_one_imm_run_from_many_threads_takes_turns(configs):
    bank = skidimm.Bank(configs / "ltc_terrains.yaml")
    t, u, z = arrays(configs, bank)
    t = np.concatenate([t + 40.0 * k for k in range(20)])  # about 30 000 rows: the runs overlap
    u, z = np.tile(u, (20, 1)), np.tile(z, (20, 1))
    expected = skidimm.Imm(bank).run(t, u, z)["mu_grass"]
    shared = skidimm.Imm(bank)
    results, errors = [None] * 4, []

    def work(i):
        try:
            for _ in range(3):
                results[i] = shared.run(t, u, z)["mu_grass"]
        except Exception as e:  # noqa: BLE001 - any exception is a failure here
            errors.append(e)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert errors == []
    for result in results:
        assert not np.isnan(result).any()
        np.testing.assert_array_equal(result, expected)  # each run whole, as if alone


def test_steps_from_many_threads_never_give_nan(configs):
    bank = skidimm.Bank(configs / "ltc_terrains.yaml")
    t, u, z = arrays(configs, bank)
    shared = skidimm.Imm(bank)
    probabilities, errors = [], []
    lock = threading.Lock()

    def work(offset):
        try:
            for k in range(offset, len(t), 4):
                e = shared.step(t[k], u[k], z[k])
                with lock:
                    probabilities.append(e.mode_probabilities)
                if k % 50 == 0:
                    shared.reset()
        except Exception as e:  # noqa: BLE001
            errors.append(e)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert errors == []
    assert len(probabilities) == len(t)
    for p in probabilities:
        assert np.isfinite(p).all() and abs(p.sum() - 1.0) < 1e-9


class CallsItsOwnImm(PythonLtc):
    """ltc_linear in Python, stepping the Imm it belongs to from inside predict."""

    imm = None

    def predict(self, x, u, dt):
        if CallsItsOwnImm.imm is not None:
            CallsItsOwnImm.imm.step(1.0, [0.0, 0.0], [0.0, 0.0])
        return super().predict(x, u, dt)


def test_an_imm_stepped_from_inside_its_own_model_raises(tmp_path, configs):
    text = (configs / "ltc_terrains.yaml").read_text().replace("model: ltc_linear", "model: py_ltc", 1)
    (tmp_path / "bank.yaml").write_text(text)
    bank = skidimm.Bank(tmp_path / "bank.yaml", models={"py_ltc": CallsItsOwnImm})
    imm = skidimm.Imm(bank)
    imm.step(0.0, [0.1, 0.1], [0.1, 0.1])
    CallsItsOwnImm.imm = imm
    try:
        with pytest.raises(RuntimeError, match="already running a step on this thread"):
            imm.step(0.1, [0.1, 0.1], [0.1, 0.1])
    finally:
        CallsItsOwnImm.imm = None
    # The Imm is usable again afterwards.
    e = imm.step(0.2, [0.1, 0.1], [0.1, 0.1])
    assert np.isfinite(e.mode_probabilities).all()


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -float("inf"), 1e308, -1e308])
def test_non_finite_and_huge_values_never_give_nan_probabilities(configs, bad):
    bank = skidimm.Bank(configs / "ltc_terrains.yaml")
    imm = skidimm.Imm(bank)
    # An infinite measurement is refused (NaN is "not measured"); anything else
    # bad in t, u or z is a step the filter survives.
    refused = np.isinf(bad)
    for t, u, z in [(0.0, [0.1, 0.1], [0.1, 0.0]), (bad, [0.1, 0.1], [0.1, 0.0]), (0.1, [bad, 0.1], [0.1, 0.0]),
                    (0.2, [0.1, 0.1], [bad, 0.0]), (0.3, [0.1, 0.1], [bad, bad]), (0.4, [0.1, 0.1], [0.1, 0.0])]:
        if refused and np.isinf(z).any():
            with pytest.raises(ValueError, match="a measurement is a finite number, or NaN"):
                imm.step(t, u, z)
            continue
        e = imm.step(t, u, z)
        assert np.isfinite(e.mode_probabilities).all(), (t, u, z, e.status)
        assert abs(e.mode_probabilities.sum() - 1.0) < 1e-9
        assert np.isfinite(e.state).all()
    n = 5
    if refused:
        with pytest.raises(ValueError, match="a measurement is a finite number, or NaN"):
            imm.run(np.full(n, bad), np.full((n, 2), bad), np.full((n, 2), bad))
    if np.isfinite(bad) and abs(bad) > 1e11:
        # A run whose times are all beyond 1e11 s is in another unit than seconds: refused, saying so.
        with pytest.raises(ValueError, match="no time in seconds"):
            imm.run(np.full(n, bad), np.full((n, 2), bad), np.full((n, 2), bad))
        return
    out = imm.run(np.full(n, bad), np.full((n, 2), bad), np.full((n, 2), np.nan if refused else bad))
    assert np.isfinite(np.column_stack([out[c] for c in out if c.startswith("mu_")])).all()


@pytest.mark.parametrize("text, says", [
    ("a = 3", "assignment"),
    ("a, b", "a ',' outside the arguments of min() or max()"),
    ("a\0+1", "a control character (byte 0)"),
    ("abs(a) + _skidimm_step99", "reserved"),
    ("mean(a)", "mean() aggregates the rows of a filter step: it is for a bank's measurements only"),
    ("_pi * a", "reserved"),
    ("sum(a, b)", "unknown function 'sum'"),
    ("a" + "+" * 10_000_000, "more than an expression may have"),
])
def test_evaluate_expression_has_the_banks_closed_language(text, says):
    columns = {"a": np.array([1.0, 2.0]), "b": np.array([3.0, 4.0])}
    with pytest.raises(skidimm.ConfigError, match="cannot parse") as raised:
        skidimm.evaluate_expression(text, columns)
    assert says in str(raised.value)
    assert len(str(raised.value)) < 400


def test_evaluate_expression_names_a_missing_column_briefly():
    with pytest.raises(KeyError, match="no column 'c'"):
        skidimm.evaluate_expression("a + c", {"a": np.array([1.0])})
