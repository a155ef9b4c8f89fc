"""LiveLog: rows pushed as a robot's callbacks push them give the steps, and
the estimates, that `skidimm run` gives for the same rows in files."""

import os
import pathlib

import numpy as np
import pytest

import skidimm

from conftest import SOURCE

SHARED_DATA = pathlib.Path(os.environ.get("SKIDIMM_SHARED_DATA_DIR", SOURCE.parent / "shared" / "data"))
PRO = ["time", "curL", "curR", "velL", "velR"]
IMU = ["time", "wx", "wy", "wz", "ax", "ay", "az"]


def write_csv(path, columns, rows):
    with open(path, "w") as f:
        f.write(",".join(columns) + "\n")
        for row in rows:
            f.write(",".join(repr(float(v)) for v in row) + "\n")


def borealtc_like(tmp_path, seed=2):
    """Wheels at 6.5 Hz and an IMU at 100 Hz on one clock, random but shaped like BorealTC's."""
    rng = np.random.default_rng(seed)
    t_pro = np.arange(0.0, 30.0, 2.0 / 13.0)
    vel = 0.3 + 0.1 * np.sin(t_pro)[:, None] + 0.02 * rng.standard_normal((len(t_pro), 2))
    pro = np.column_stack([t_pro, 10 + rng.standard_normal((len(t_pro), 2)), vel])
    t_imu = np.arange(0.003, 30.0, 0.01)
    imu = np.column_stack([t_imu, 0.05 * rng.standard_normal((len(t_imu), 3)),
                           rng.standard_normal((len(t_imu), 3)) + [0.0, 0.0, 9.8]])
    write_csv(tmp_path / "pro.csv", PRO, pro)
    write_csv(tmp_path / "imu.csv", IMU, imu)
    return pro, imu


def run_live(bank, pro, imu, seed):
    """Rows pushed in random bursts, each burst's steps run at once, continuing the filter."""
    live = skidimm.LiveLog(bank, {"pro": PRO, "imu": IMU})
    imm = skidimm.Imm(bank)
    rng = np.random.default_rng(seed)
    at = {"pro": 0, "imu": 0}
    tables = {"pro": pro, "imu": imu}
    chunks = []

    def take():
        t, u, z = live.steps()
        assert u.shape == (len(t), len(bank.inputs)) and z.shape == (len(t), len(bank.measurements))
        if len(t):
            chunks.append(imm.run(t, u, z, reset=not chunks))

    while any(at[k] < len(tables[k]) for k in tables):
        name = "pro" if at["imu"] >= len(imu) or (at["pro"] < len(pro) and rng.random() < 0.1) else "imu"
        n = int(rng.integers(1, 4 if name == "pro" else 40))
        live.push(name, tables[name][at[name]:at[name] + n])  # several rows at once: a 2-D array
        at[name] += n
        take()
    live.close()
    take()
    assert live.ended
    return {k: np.concatenate([c[k] for c in chunks]) for k in chunks[0]}, live


def assert_same_estimates(got, expected):
    for name, column in got.items():
        if column.dtype == object:
            assert list(column) == list(expected[name]), name
        else:
            np.testing.assert_array_equal(column, expected[name], err_msg=name)


def test_pushed_rows_give_run_logs_estimates_exactly(tmp_path, configs):
    bank = skidimm.Bank(configs / "borealtc" / "terrains.yaml")
    pro, imu = borealtc_like(tmp_path)
    expected = skidimm.run_log(bank, f"{tmp_path / 'pro.csv'}+{tmp_path / 'imu.csv'}")
    for seed in (1, 2):
        got, live = run_live(bank, pro, imu, seed)
        assert len(got["t"]) == len(expected["t"]) > 50
        assert_same_estimates(got, expected)
    assert "not used" in live.describe_stats()  # the rows after the last step, as `run` says
    assert live.unmeasured() == []


def test_the_real_borealtc_run_live_equals_run_log(configs):
    ice = SHARED_DATA / "borealtc" / "ICE"
    if not ice.exists():
        pytest.skip(f"no shared data at {ice}")
    bank = skidimm.Bank(configs / "borealtc" / "terrains.yaml")
    pro = np.loadtxt(ice / "pro_02.csv", delimiter=",", skiprows=1)
    imu = np.loadtxt(ice / "imu_02.csv", delimiter=",", skiprows=1)
    assert open(ice / "pro_02.csv").readline().strip().split(",") == PRO
    assert open(ice / "imu_02.csv").readline().strip().split(",") == IMU
    got, _ = run_live(bank, pro, imu, seed=7)
    assert_same_estimates(got, skidimm.run_log(bank, f"{ice / 'pro_02.csv'}+{ice / 'imu_02.csv'}"))


def test_the_ros2_bank_runs_live_on_tables_named_by_topic(configs):
    """terrains_ros2.yaml names its columns by topic and field path, as a node's subscriptions give them."""
    ice = SHARED_DATA / "borealtc" / "ICE"
    if not ice.exists():
        pytest.skip(f"no shared data at {ice}")
    bank = skidimm.Bank(configs / "borealtc" / "terrains_ros2.yaml")
    live = skidimm.LiveLog(bank, {
        "/joint_states": ["header.stamp", "/joint_states.effort[left]", "/joint_states.effort[right]",
                          "/joint_states.velocity[left]", "/joint_states.velocity[right]"],
        "/imu/data": ["header.stamp"] + [f"/imu/data.{v}.{c}" for v in ("angular_velocity", "linear_acceleration")
                                         for c in "xyz"]})
    live.push("/joint_states", np.loadtxt(ice / "pro_02.csv", delimiter=",", skiprows=1))
    live.push("/imu/data", np.loadtxt(ice / "imu_02.csv", delimiter=",", skiprows=1))
    live.close()
    got = skidimm.Imm(bank).run(*live.steps())
    expected = skidimm.run_log(configs / "borealtc" / "terrains.yaml", f"{ice / 'pro_02.csv'}+{ice / 'imu_02.csv'}")
    modes = [k for k in expected if k.startswith("mu_")]
    assert len(modes) == 10
    for name in modes + ["t", "mode"]:
        assert list(got[name]) == list(expected[name]), name


def test_a_step_waits_for_every_open_table(configs):
    bank = skidimm.Bank(configs / "borealtc" / "terrains.yaml")
    live = skidimm.LiveLog(bank, {"pro": PRO, "imu": IMU})
    assert live.tables == {"pro": PRO, "imu": IMU}
    for k in range(10):
        live.push("pro", [k * 0.2, 10.0, 10.0, 0.3, 0.3])
    t, _, _ = live.steps()
    assert len(t) == 0  # no IMU row yet
    assert live.waiting_for == ("imu", None)
    for k in range(120):
        live.push(1, [k * 0.01, 0.01 * (k % 2), 0.02 * (k % 3), 0.01 * (k % 3), 0.1 * (k % 5), 0.1 * (k % 4),
                      9.8 + 0.1 * (k % 7)])
    t, _, z = live.steps()
    np.testing.assert_array_equal(t, [0.0, 0.5, 1.0])  # the grid at 2 Hz, as far as the IMU has come (t = 1.19)
    assert np.isfinite(z[1]).all()
    live.close("imu")
    t, _, _ = live.steps()
    np.testing.assert_array_equal(t, [1.5])  # the wheels alone, up to their last row (1.8)
    assert not live.ended
    assert live.waiting_for == ("pro", 1.8)
    live.close()
    live.steps()
    assert live.ended
    assert live.waiting_for is None


def test_errors_name_the_table_the_row_and_the_column(configs):
    bank = skidimm.Bank(configs / "borealtc" / "terrains.yaml")
    with pytest.raises(skidimm.Error, match="'curL'"):
        skidimm.LiveLog(bank, {"pro": ["time", "velL", "velR"], "imu": IMU})
    with pytest.raises(ValueError, match="offsets: no table named 'gps'"):
        skidimm.LiveLog(bank, {"pro": PRO, "imu": IMU}, offsets={"gps": 0.1})
    # As a file's @OFFSET: past 1e11 s times cannot tell rows apart; a Unix time is a fine offset.
    with pytest.raises(skidimm.Error, match=r"live table 'imu': the time offset must be finite and at most 1e11 s"):
        skidimm.LiveLog(bank, {"pro": PRO, "imu": IMU}, offsets={"imu": 1e17})
    skidimm.LiveLog(bank, {"pro": PRO, "imu": IMU}, offsets={"imu": -1.7e9}).close()
    live = skidimm.LiveLog(bank, {"pro": PRO, "imu": IMU}, offsets={"imu": 0.0})
    with pytest.raises(skidimm.Error, match="no table 'odom'; its tables: 'pro', 'imu'"):
        live.push("odom", [0.0])
    with pytest.raises(skidimm.Error, match=r"live table 'pro': a row has 3 value\(s\), the table 5 column\(s\)"):
        live.push("pro", [0.0, 1.0, 2.0])
    with pytest.raises(ValueError, match="a sequence of numbers"):
        live.push("pro", "0,1,2,3,4")
    live.push("pro", [0.0, 10.0, 10.0, 0.3, 0.3])
    live.push("pro", [2.0, 10.0, 10.0, 0.3, 0.3])
    live.push("imu", [[k * 0.01, 0.01 * (k % 2), 0.0, 0.0, 0.1 * (k % 3), 0.0, 9.8] for k in range(120)])
    live.push("imu", [0.4, 0.0, 0.0, 0.0, 0.0, 0.0, 9.8])  # back in time, in the step at 1.5
    t, _, _ = live.steps()
    np.testing.assert_array_equal(t, [0.0, 0.5, 1.0])  # every step before the refused row first
    with pytest.raises(skidimm.LogError, match="live table 'imu': row 121: column 'time': time must increase"):
        live.steps()
    with pytest.raises(skidimm.LogError, match="row 121"):
        live.steps()  # and again
    stalled = skidimm.LiveLog(bank, {"pro": PRO, "imu": IMU})
    stalled.max_queued_rows = 1
    stalled.push("pro", [0.0, 10.0, 10.0, 0.3, 0.3])  # the reader takes it, and waits for the IMU
    assert stalled.waiting_for == ("imu", None)
    with pytest.raises(skidimm.Error, match=r"row 1 of the 2 given \(those before it were pushed\): live table 'pro' "
                                            r"holds 1 rows the reader has not taken \(max_queued_rows\): the reader "
                                            "waits for a row of live table 'imu' \\(0 row\\(s\\) pushed\\)"):
        stalled.push("pro", [[1.0, 10.0, 10.0, 0.3, 0.3], [2.0, 10.0, 10.0, 0.3, 0.3]])
    with pytest.raises(skidimm.Error, match="live table 'pro' was closed: no row may follow"):
        stalled.close("pro")
        stalled.push("pro", [3.0, 10.0, 10.0, 0.3, 0.3])
