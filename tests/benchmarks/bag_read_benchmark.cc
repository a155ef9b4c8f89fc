// A drive's steps from each source a robot's data reaches the filter by,
// against reading the same data from CSV files.
//
// bag_read/<storage>: a ROS 2 bag (docs/ros2.md). It reads a synthetic BorealTC-like drive of
// SKIDIMM_BENCHMARK_BAG_SECONDS seconds (default 1800: an IMU at 100 Hz and
// wheel speeds and currents at 6.5 Hz) through LogReader, the steps
// `skidimm run` would filter (configs/borealtc/terrains.yaml's 2 Hz grid with
// its mean/std aggregates), once from the CSV pair and once from a bag of
// the same numbers, in the same iteration. Counters: CPU seconds per read of
// each, and bag_over_csv, the ratio (below 1: the bag is faster). Both
// reads must give the same steps, bit for bit, or the benchmark fails.
//   <storage>: mcap_zstd (rosbag2's default) and mcap (uncompressed chunks),
// written by skidimm's own McapWriter with CDR laid out here by hand;
// their correctness against the npm packages is the tests' job.
//
// live_log/borealtc: the same drive's rows pushed into a LiveLog (live_log.h)
// one message at a time, in time order, its steps taken after every push, as
// a node's callbacks would: against reading the CSV pair, in the same
// iteration. Counters: CPU seconds of the whole process per read (the
// LiveLog's reader runs on a thread of its own), live_over_csv, and
// us_per_row, the CPU time per message pushed. Both must give the same
// steps, bit for bit.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <random>
#include <string>
#include <vector>

#include "benchmark_data.h"
#include "ros/mcap_writer.h"
#include "skidimm/config/bank.h"
#include "skidimm/io/csv.h"
#include "skidimm/io/live_log.h"
#include "skidimm/io/log_reader.h"

namespace skidimm_bench {
namespace {

double bag_seconds() {
  const char* s = std::getenv("SKIDIMM_BENCHMARK_BAG_SECONDS");
  return s != nullptr ? std::atof(s) : 1800.0;
}

std::filesystem::path bag_directory() {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "skidimm_benchmark_bags";
  std::filesystem::create_directories(dir);
  return dir;
}

// Little-endian CDR, as ROS 2 serializes it (alignment from after the
// 4-byte encapsulation header).
class Cdr {
 public:
  Cdr() : bytes_{0, 1, 0, 0} {}
  void align(std::size_t n) {
    while ((bytes_.size() - 4) % n != 0) bytes_.push_back(0);
  }
  template <typename T>
  void put(T v) {
    align(sizeof(T));
    const auto* p = reinterpret_cast<const unsigned char*>(&v);
    bytes_.insert(bytes_.end(), p, p + sizeof(T));
  }
  void string(const std::string& s) {
    put<std::uint32_t>(static_cast<std::uint32_t>(s.size() + 1));
    bytes_.insert(bytes_.end(), s.begin(), s.end());
    bytes_.push_back(0);
  }
  void header(std::int64_t ns, const std::string& frame) {
    put<std::int32_t>(static_cast<std::int32_t>(ns / 1000000000));
    put<std::uint32_t>(static_cast<std::uint32_t>(ns % 1000000000));
    string(frame);
  }
  const std::vector<unsigned char>& bytes() const { return bytes_; }

 private:
  std::vector<unsigned char> bytes_;
};

constexpr const char* kImuDefinition =
    "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\nfloat64[9] orientation_covariance\n"
    "geometry_msgs/Vector3 angular_velocity\nfloat64[9] angular_velocity_covariance\n"
    "geometry_msgs/Vector3 linear_acceleration\nfloat64[9] linear_acceleration_covariance\n"
    "================================================================================\nMSG: std_msgs/Header\n"
    "builtin_interfaces/Time stamp\nstring frame_id\n"
    "================================================================================\nMSG: builtin_interfaces/Time\n"
    "int32 sec\nuint32 nanosec\n"
    "================================================================================\nMSG: geometry_msgs/Quaternion\n"
    "float64 x\nfloat64 y\nfloat64 z\nfloat64 w\n"
    "================================================================================\nMSG: geometry_msgs/Vector3\n"
    "float64 x\nfloat64 y\nfloat64 z\n";
constexpr const char* kJointDefinition =
    "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n"
    "================================================================================\nMSG: std_msgs/Header\n"
    "builtin_interfaces/Time stamp\nstring frame_id\n"
    "================================================================================\nMSG: builtin_interfaces/Time\n"
    "int32 sec\nuint32 nanosec\n";

struct Drive {
  std::filesystem::path pro, imu, mcap_zstd, mcap;
};

// The same numbers as CSV text (shortest round trip) and as CDR doubles.
// Times are whole multiples of 10 ms (IMU) and 2/13 s rounded to the
// nanosecond (joints), written as their exact decimals in the CSV.
Drive make_drive(double seconds) {
  const std::string tag = std::to_string(static_cast<long>(seconds));
  const std::filesystem::path dir = bag_directory();
  Drive d{dir / ("pro_" + tag + ".csv"), dir / ("imu_" + tag + ".csv"), dir / ("drive_zstd_" + tag + ".mcap"),
          dir / ("drive_" + tag + ".mcap")};
  if (std::filesystem::exists(d.mcap)) return d;
  std::mt19937_64 random(27);
  std::normal_distribution<double> noise(0.0, 1.0);
  skidimm::CsvWriter pro(d.pro, {"time", "curL", "curR", "velL", "velR"});
  skidimm::CsvWriter imu(d.imu, {"time", "wx", "wy", "wz", "ax", "ay", "az"});
  std::vector<std::unique_ptr<skidimm::ros::McapWriter>> bags;
  for (const std::string compression : {"zstd", ""}) {
    skidimm::ros::McapWriter::Options options;
    options.profile = "ros2";
    options.compression = compression;
    bags.push_back(std::make_unique<skidimm::ros::McapWriter>(compression.empty() ? d.mcap : d.mcap_zstd, options));
  }
  std::vector<std::uint16_t> imu_channel, joint_channel;
  for (auto& bag : bags) {
    imu_channel.push_back(bag->add_channel("/imu/data", "cdr", bag->add_schema("sensor_msgs/msg/Imu", "ros2msg", kImuDefinition)));
    joint_channel.push_back(
        bag->add_channel("/joint_states", "cdr", bag->add_schema("sensor_msgs/msg/JointState", "ros2msg", kJointDefinition)));
  }
  auto ns_text = [](std::int64_t ns) {
    char text[40];
    std::snprintf(text, sizeof(text), "%lld.%09lld", static_cast<long long>(ns / 1000000000),
                  static_cast<long long>(ns % 1000000000));
    return std::string(text);
  };
  const std::int64_t end = static_cast<std::int64_t>(seconds * 1e9);
  std::int64_t next_imu = 0, next_joint = 0;
  long joints = 0;
  while (next_imu < end || next_joint < end) {
    if (next_joint <= next_imu) {
      const double v = 0.3 + 0.05 * std::sin(1e-9 * static_cast<double>(next_joint));
      const double values[4] = {8 + noise(random), 7 + noise(random), v + 0.01 * noise(random), v - 0.02 + 0.01 * noise(random)};
      pro.add_text(ns_text(next_joint));
      for (double x : values) pro.add_number(x);
      pro.end_row();
      Cdr m;
      m.header(next_joint, "base_link");
      m.put<std::uint32_t>(2);
      m.string("left");
      m.string("right");
      m.put<std::uint32_t>(0);
      m.put<std::uint32_t>(2);
      m.put(values[2]);
      m.put(values[3]);
      m.put<std::uint32_t>(2);
      m.put(values[0]);
      m.put(values[1]);
      for (std::size_t b = 0; b < bags.size(); ++b) {
        bags[b]->write(joint_channel[b], static_cast<std::uint64_t>(next_joint), static_cast<std::uint64_t>(next_joint),
                       m.bytes().data(), m.bytes().size());
      }
      ++joints;
      next_joint = (joints * 2000000000 + 6) / 13;  // 2/13 s, to the nearest nanosecond
      continue;
    }
    const double values[6] = {0.01 * noise(random), 0.01 * noise(random), 0.1 * noise(random),
                              0.5 * noise(random),  0.5 * noise(random),  9.81 + 0.5 * noise(random)};
    imu.add_text(ns_text(next_imu));
    for (double x : values) imu.add_number(x);
    imu.end_row();
    Cdr m;
    m.header(next_imu, "imu_link");
    for (double q : {0.0, 0.0, 0.0, 1.0}) m.put(q);
    for (int k = 0; k < 9; ++k) m.put(k == 0 ? -1.0 : 0.0);
    for (int k = 0; k < 3; ++k) m.put(values[k]);
    for (int k = 0; k < 9; ++k) m.put(0.0);
    for (int k = 3; k < 6; ++k) m.put(values[k]);
    for (int k = 0; k < 9; ++k) m.put(0.0);
    for (std::size_t b = 0; b < bags.size(); ++b) {
      bags[b]->write(imu_channel[b], static_cast<std::uint64_t>(next_imu), static_cast<std::uint64_t>(next_imu),
                     m.bytes().data(), m.bytes().size());
    }
    next_imu += 10000000;
  }
  pro.commit();
  imu.commit();
  for (auto& bag : bags) bag->commit();
  return d;
}

// CPU seconds of this thread: the machine is shared, wall time is noise.
double cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// A step's time, inputs and measurements appended to *digest, for the
// comparison of two sources' steps.
void append_step(const skidimm::LogSample& sample, std::vector<double>* digest) {
  digest->push_back(sample.t);
  for (Eigen::Index i = 0; i < sample.u.size(); ++i) digest->push_back(sample.u[i]);
  for (Eigen::Index i = 0; i < sample.z.size(); ++i) digest->push_back(sample.z[i]);
}

// Reads every step; returns them for the comparison and the CPU seconds taken.
double read_steps(const skidimm::BankConfig& bank, const std::vector<skidimm::LogFile>& files,
                  std::vector<double>* digest) {
  const double start = cpu_seconds();
  skidimm::LogReader reader(bank, files);
  skidimm::LogSample sample;
  digest->clear();
  while (reader.next(&sample)) {
    append_step(sample, digest);
  }
  return cpu_seconds() - start;
}

bool same(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (!(a[i] == b[i] || (std::isnan(a[i]) && std::isnan(b[i])))) return false;
  }
  return true;
}

void bag_read(benchmark::State& state, bool compressed) {
  const Drive drive = make_drive(bag_seconds());
  const skidimm::BankConfig csv_bank = skidimm::load_bank_config(source_dir() / "configs/borealtc/terrains.yaml");
  const skidimm::BankConfig bag_bank = skidimm::load_bank_config(source_dir() / "configs/borealtc/terrains_ros2.yaml");
  const std::filesystem::path bag = compressed ? drive.mcap_zstd : drive.mcap;
  double csv_seconds = 0.0, bag_time = 0.0;
  std::vector<double> from_csv, from_bag;
  for (auto _ : state) {
    csv_seconds += read_steps(csv_bank, {skidimm::LogFile(drive.pro), skidimm::LogFile(drive.imu)}, &from_csv);
    bag_time += read_steps(bag_bank, {skidimm::LogFile(bag)}, &from_bag);
    if (!same(from_csv, from_bag)) {
      state.SkipWithError("the bag and the CSV pair gave different steps");
      return;
    }
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["csv_s"] = csv_seconds / n;
  state.counters["bag_s"] = bag_time / n;
  state.counters["bag_over_csv"] = bag_time / csv_seconds;
  state.counters["steps"] = static_cast<double>(from_csv.size()) / static_cast<double>(1 + 3 + 9);
}

// CPU seconds of the whole process: a LiveLog's reader is a thread of its own.
double process_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// A CSV file's rows as numbers (the drive's files have no blank cell).
std::vector<std::vector<double>> rows_of(const std::filesystem::path& file) {
  skidimm::CsvReader reader(file);
  std::vector<std::vector<double>> rows;
  while (reader.next_row()) {
    std::vector<double> row;
    for (std::size_t c = 0; c < reader.header().size(); ++c)
      row.push_back(std::strtod(std::string(reader.field(static_cast<int>(c))).c_str(), nullptr));
    rows.push_back(std::move(row));
  }
  return rows;
}

void live_log(benchmark::State& state) {
  const Drive drive = make_drive(bag_seconds());
  const skidimm::BankConfig bank = skidimm::load_bank_config(source_dir() / "configs/borealtc/terrains.yaml");
  const std::vector<std::vector<double>> pro = rows_of(drive.pro), imu = rows_of(drive.imu);
  const std::vector<std::string> pro_columns = {"time", "curL", "curR", "velL", "velR"};
  const std::vector<std::string> imu_columns = {"time", "wx", "wy", "wz", "ax", "ay", "az"};
  double csv_seconds = 0.0, live_seconds = 0.0;
  std::vector<double> from_csv, from_live;
  for (auto _ : state) {
    double start = process_cpu_seconds();
    read_steps(bank, {skidimm::LogFile(drive.pro), skidimm::LogFile(drive.imu)}, &from_csv);
    csv_seconds += process_cpu_seconds() - start;
    start = process_cpu_seconds();
    {
      skidimm::LiveLog live(bank, {{"pro", pro_columns}, {"imu", imu_columns}});
      from_live.clear();
      skidimm::LogSample sample;
      const auto take = [&] {
        while (live.next(&sample)) append_step(sample, &from_live);
      };
      std::size_t p = 0, i = 0;
      while (p < pro.size() || i < imu.size()) {  // the messages in time order, as they arrive
        if (i == imu.size() || (p < pro.size() && pro[p][0] <= imu[i][0])) {
          live.push(0, pro[p++]);
        } else {
          live.push(1, imu[i++]);
        }
        take();
      }
      live.close();
      take();
    }
    live_seconds += process_cpu_seconds() - start;
    if (!same(from_csv, from_live)) {
      state.SkipWithError("the LiveLog and the CSV pair gave different steps");
      return;
    }
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["csv_s"] = csv_seconds / n;
  state.counters["live_s"] = live_seconds / n;
  state.counters["live_over_csv"] = live_seconds / csv_seconds;
  state.counters["us_per_row"] = 1e6 * live_seconds / n / static_cast<double>(pro.size() + imu.size());
  state.counters["steps"] = static_cast<double>(from_csv.size()) / static_cast<double>(1 + 3 + 9);
}

BENCHMARK_CAPTURE(bag_read, mcap_zstd, true)->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK_CAPTURE(bag_read, mcap, false)->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(live_log)->Name("live_log/borealtc")->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace
}  // namespace skidimm_bench
