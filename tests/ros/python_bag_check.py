"""The Python package and its Dask helpers read ROS 2 bags as the CLI does:
skidimm.run_log on a bag equals skidimm.run_log on the CSV pair it was
written from (every column, exactly), and skidimm.dask.eval over bags on a
local cluster equals skidimm.eval over the CSV pairs. Run by
ros2_equivalence_test.sh with the bags it wrote.

    python_bag_check.py SOURCE_DIR DATA_DIR BAGS_DIR
"""
import math
import os
import sys


def same(a, b):
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


def main():
    source, data, bags = sys.argv[1:4]
    import skidimm
    import skidimm.dask
    from distributed import Client, LocalCluster

    csv_bank = os.path.join(source, "configs/borealtc/terrains.yaml")
    bag_bank = os.path.join(source, "configs/borealtc/terrains_ros2.yaml")
    terrain = "ICE"
    runs = sorted(f[len("pro_"):-len(".csv")] for f in os.listdir(os.path.join(data, terrain)) if f.startswith("pro_"))
    checked = 0
    for n in runs[:3]:
        pro = os.path.join(data, terrain, f"pro_{n}.csv")
        imu = os.path.join(data, terrain, f"imu_{n}.csv")
        bag = [os.path.join(bags, terrain, f) for f in os.listdir(os.path.join(bags, terrain))
               if f.startswith(f"{terrain}_{n}")][0]
        a = skidimm.run_log(csv_bank, f"{pro}+{imu}")
        b = skidimm.run_log(bag_bank, bag)
        assert list(a) == list(b), (list(a), list(b))
        for column in a:
            x, y = list(a[column]), list(b[column])
            assert len(x) == len(y) and all(same(p, q) for p, q in zip(x, y)), f"{bag}: column {column} differs"
        checked += 1
    csv_inputs = [f"{terrain}={data}/{terrain}/pro_*.csv+{data}/{terrain}/imu_*.csv"]
    bag_inputs = [f"{terrain}={bags}/{terrain}"]
    local = skidimm.eval(csv_bank, csv_inputs)
    with LocalCluster(n_workers=2, processes=True, threads_per_worker=1, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        remote = skidimm.dask.eval(client, bag_bank, bag_inputs)
    assert local["overall"] == remote["overall"], (local["overall"], remote["overall"])
    assert local["groups"] == remote["groups"]
    print(f"Python: run_log on {checked} bags equals run_log on their CSV pairs; "
          f"skidimm.dask.eval over {remote['overall']['logs']} {terrain} bags equals skidimm.eval over the CSV pairs")


if __name__ == "__main__":
    main()
