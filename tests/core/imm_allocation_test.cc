// step() must not touch the heap after construction: a robot's control loop
// cannot afford allocator latency. malloc itself is counted, so Eigen's
// allocations are seen too, not only operator new.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "core/malloc_counter.h"
#include "core/test_banks.h"
#include "skidimm/engine/decision.h"
#include "skidimm/engine/imm.h"
#include "skidimm/engine/log_run.h"
#include "skidimm/io/estimates_writer.h"
#include "skidimm/io/log_reader.h"
#include "stc_kinematic/stc_kinematic_model.h"
#include "stc_traction/stc_traction_model.h"

namespace skidimm {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

TEST(ImmAllocation, StepAndDecisionAllocateNothingWithIrregularTimeMissingRowsAndAngles) {
  SKIDIMM_SKIP_UNLESS_MALLOC_COUNTED();
  // 16 STC modes (EKF with an angle), dwell-time transitions with unequal
  // rates (the uniformisation path), irregular dt, partial measurements.
  skidimm_test::BankBuilder b;
  b.states = {"X", "Y", "theta"};
  b.angles = {false, false, true};
  b.inputs = {"phi_dot_L", "phi_dot_R"};
  for (int j = 0; j < 16; ++j) {
    sdk::ParameterSet p;
    p.set_scalar("k", 0.6 + 0.025 * j);
    p.set_scalar("m", 0.5 + 0.03 * j);
    p.set_scalar("r", 0.165);
    p.set_scalar("b", 0.555);
    std::string error;
    b.models.push_back(std::shared_ptr<sdk::MotionModel>(plugins::StcKinematicModel::Create(p, &error).release()));
  }
  b.q = {Eigen::Matrix3d::Identity() * 1e-3};
  b.r = Eigen::Matrix3d::Identity() * 1e-3;
  Bank bank = b.build();
  bank.config.transition.kind = TransitionConfig::Kind::kDwellTimes;
  bank.config.transition.dwell_seconds = Eigen::VectorXd::LinSpaced(16, 5.0, 20.0);
  bank.config.classes.push_back(ClassConfig{"first_eight", {0, 1, 2, 3, 4, 5, 6, 7}});
  Imm imm(std::move(bank));
  ModeDecision decision(imm.config());

  const Eigen::Vector2d u(3.0, 4.0);
  Eigen::Vector3d z(0.0, 0.0, 0.0);
  double t = 0.0;
  auto run = [&](int steps) {
    for (int k = 0; k < steps; ++k) {
      t += 0.02 + 0.01 * std::sin(0.37 * k);
      z = Eigen::Vector3d(0.5 * t, 0.1 * t, std::remainder(3.0 + 0.3 * t, 2.0 * M_PI));
      if (k % 5 != 0) z[0] = z[1] = kNaN;    // GPS at a fifth of the rate
      if (k % 11 == 0) z.setConstant(kNaN);  // nothing measured at all
      decision.update(t, imm.step(t, u, z).mode_probabilities);
    }
  };
  {
    // The counter must see Eigen's own heap use, or the check below proves nothing.
    const long calls = skidimm_test::g_malloc_calls.load();
    Eigen::MatrixXd workspace(16, 16);
    workspace.setZero();
    ASSERT_GT(skidimm_test::g_malloc_calls.load(), calls);
  }
  run(10);  // warm-up
  const long before = skidimm_test::g_malloc_calls.load();
  run(1000);
  EXPECT_EQ(skidimm_test::g_malloc_calls.load() - before, 0) << "heap allocations during 1000 steps and decisions";
  EXPECT_TRUE(imm.estimate().state.allFinite());
}

// A bank measuring model outputs besides the pose: each mode's outputs are
// computed and subtracted in place, in the fixed-size kernel (the pose and
// the gyro: 4 rows) and the dynamic one (the gyro and stc_traction's motor
// currents too: 6 rows).
// Measured outputs, with the bank's R and with modes that have their own
// (every other mode: the dynamic kernel then rewrites the selected block per
// mode).
TEST(ImmAllocation, MeasuredOutputsAllocateNothing) {
  SKIDIMM_SKIP_UNLESS_MALLOC_COUNTED();
  for (const int case_index : {0, 1, 2, 3}) {
    const int outputs = case_index % 2 ? 3 : 1;
    const bool own_noise = case_index >= 2;
    skidimm_test::BankBuilder b;
    b.states = {"X", "Y", "theta"};
    b.angles = {false, false, true};
    b.inputs = {"phi_dot_L", "phi_dot_R"};
    const char* names[] = {
        "eta_l", "eta_r",  "alpha_l_outer", "alpha_l_inner", "alpha_r_outer", "alpha_r_inner", "x_icr",     "r",
        "b",     "k_skid_l", "k_skid_r", "i_straight", "i_l_outer", "i_l_inner", "i_r_outer", "i_r_inner", "s_peak"};
    for (int j = 0; j < 4; ++j) {
      const double values[] = {0.9,   0.95,    1.5 + 0.2 * j, 1.4,     1.6, 1.3, 0.0, 0.165,
                               0.555, 5.0 * j, 3.0 * j, 2.0, 8.0 - j, 7.0, 6.0, 5.0, 0.1};
      sdk::ParameterSet p;
      for (int i = 0; i < 17; ++i) p.set_scalar(names[i], values[i]);
      std::string error;
      b.models.push_back(std::shared_ptr<sdk::MotionModel>(plugins::StcTractionModel::Create(p, &error).release()));
    }
    b.q = {Eigen::Matrix3d::Identity() * 1e-3};
    b.h = Eigen::MatrixXd::Zero(3 + outputs, 3);
    b.h.topRows(3).setIdentity();
    b.r = Eigen::VectorXd::Constant(3 + outputs, 1e-2).asDiagonal();
    Bank bank = b.build();
    bank.config.measurement.outputs = {"omega", "i_L", "i_R"};
    bank.config.measurement.outputs.resize(static_cast<std::size_t>(outputs));
    if (own_noise) {
      for (int j = 0; j < 4; j += 2) {
        bank.config.modes[static_cast<std::size_t>(j)].r = Eigen::VectorXd::Constant(3 + outputs, 4e-2).asDiagonal();
      }
    }
    Imm imm(std::move(bank));
    EXPECT_TRUE(imm.uses_fixed_size_kernel());
    double t = 0.0;
    Eigen::VectorXd full(6);
    auto run = [&](int steps) {
      for (int k = 0; k < steps; ++k) {
        t += 0.02;
        full << 0.5 * t, 0.1 * t, std::remainder(0.3 * t, 2.0 * M_PI), 0.3, 6.0, 5.5;
        if (k % 5 != 0) full.head(3).setConstant(kNaN);  // GPS at a fifth of the rate
        if (k % 3 != 0) full.tail(2).setConstant(kNaN);  // currents at a third
        imm.step(t, Eigen::Vector2d(3.0, 4.0 + std::sin(0.1 * k)), full.head(3 + outputs));
      }
    };
    run(10);  // warm-up
    const long before = skidimm_test::g_malloc_calls.load();
    run(500);
    EXPECT_EQ(skidimm_test::g_malloc_calls.load() - before, 0)
        << outputs << " output(s) measured" << (own_noise ? ", modes with their own R" : "");
    EXPECT_TRUE(imm.estimate().state.allFinite());
  }
}

// Every kernel and every path of the dwell-time transition (with correlated
// innovations, whose memory restarts when a row is missing): the dynamic
// kernel, 64 modes (products past Eigen's small-size paths), steps jittered
// in their last digits, alternating rates (several anchors), and gaps long
// enough for the eigenvector path.
TEST(ImmAllocation, EveryKernelAndTransitionPathAllocatesNothing) {
  SKIDIMM_SKIP_UNLESS_MALLOC_COUNTED();
  for (ImmKernelChoice choice : {ImmKernelChoice::kFastest, ImmKernelChoice::kDynamic}) {
    for (TransitionConfig::Kind kind :
         {TransitionConfig::Kind::kStay, TransitionConfig::Kind::kDwellTimes, TransitionConfig::Kind::kMatrix}) {
      skidimm_test::BankBuilder b;
      b.states = {"V", "omega"};
      b.angles = {false, false};
      b.inputs = {"phi_dot_L", "phi_dot_R"};
      Eigen::Matrix2d input;
      input << 0.4, 0.4, -0.8, 0.8;
      for (int j = 0; j < 64; ++j) {
        b.models.push_back(skidimm_test::make_ltc(Eigen::Matrix2d::Identity() * -(1.0 + 0.1 * j), 0.3 * input));
      }
      b.q = {Eigen::Matrix2d::Identity() * 0.01};
      b.r = Eigen::Matrix2d::Identity() * 0.01;
      Bank bank = b.build();
      bank.config.transition.kind = kind;
      bank.config.transition.dwell_seconds = Eigen::VectorXd::LinSpaced(64, 0.2, 20.0);
      bank.config.transition.matrix = Eigen::MatrixXd::Constant(64, 64, 0.01 / 63);
      bank.config.transition.matrix.diagonal().setConstant(0.99);
      // Correlated innovations: their memory is sized once too.
      for (ModeConfig& mode : bank.config.modes) mode.residual_correlation = 0.5;
      Imm imm(std::move(bank), choice);
      double t = 0.0;
      auto run = [&](int steps) {
        for (int k = 0; k < steps; ++k) {
          const double dt = k % 50 == 49   ? 400.0                                  // a gap: eigenvectors
                            : k % 3 == 0   ? 0.01 + 1e-7 * std::sin(0.37 * k)       // jitter: one anchor
                            : k % 3 == 1   ? 0.0035                                  // merged files:
                                           : 0.154;                                  // other anchors
          t += dt;
          Eigen::Vector2d z(0.5 + 0.1 * std::sin(t), 0.1);
          if (k % 7 == 0) z[0] = kNaN;
          imm.step(t, Eigen::Vector2d(3.0, 4.0), z);
        }
      };
      run(60);  // warm-up
      const long before = skidimm_test::g_malloc_calls.load();
      run(300);
      EXPECT_EQ(skidimm_test::g_malloc_calls.load() - before, 0)
          << (choice == ImmKernelChoice::kDynamic ? "dynamic" : "fixed-size") << " kernel, transition kind "
          << static_cast<int>(kind);
      EXPECT_TRUE(imm.estimate().state.allFinite());
    }
  }
}

// `skidimm run`'s whole loop (log_run.h, write_estimates): reading the log in
// place, stepping, deciding, writing CSV or .npy. After the first rows (the
// Imm, its workspaces, the first labels), the only allocations left are the
// mode timeline's amortised growth: at most one per doubling of its
// intervals, O(log rows) over a log, none per row.
std::filesystem::path tiled_log(const std::string& example, int copies) {
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / "skidimm_allocation_run";
  std::filesystem::create_directories(dir);
  const std::filesystem::path path = dir / (example + ".csv");
  std::ifstream in(std::filesystem::path(SKIDIMM_SOURCE_DIR) / "configs" / "examples" / (example + ".csv"));
  std::string header, line;
  std::getline(in, header);
  std::vector<std::pair<double, std::string>> rows;
  while (std::getline(in, line)) {
    const auto comma = line.find(',');
    rows.emplace_back(std::stod(line.substr(0, comma)), line.substr(comma));
  }
  const double period = rows.back().first + 0.02;
  std::ofstream out(path);
  out << header << "\n";
  char t[32];
  for (int c = 0; c < copies; ++c) {
    for (const auto& [time, rest] : rows) {
      std::snprintf(t, sizeof(t), "%.4f", time + period * c);
      out << t << rest << "\n";
    }
  }
  return path;
}

TEST(ImmAllocation, TheRunLoopAllocatesNothingPerRow) {
  SKIDIMM_SKIP_UNLESS_MALLOC_COUNTED();
  for (const char* bank_name : {"ltc_terrains", "stc_slip16"}) {
    for (const char* extension : {".csv", ".npy"}) {
      SCOPED_TRACE(std::string(bank_name) + extension);
      const Bank bank =
          Bank::load(std::filesystem::path(SKIDIMM_SOURCE_DIR) / "configs" / (std::string(bank_name) + ".yaml"),
                     {SKIDIMM_PLUGIN_DIR});
      const std::filesystem::path log =
          tiled_log(std::string(bank_name).rfind("ltc", 0) == 0 ? "ltc_switching" : "stc_switching", 12);
      LogReader reader(bank.config, {log});
      EstimatesWriter writer(log.parent_path() / (std::string("out_") + bank_name + extension), bank.config, true);
      RunSummary summary;
      long before = -1, rows_before = 0;
      write_estimates(bank, &reader, {}, bank.config.decision, "", true, &writer, &summary, [&] {
        if (before >= 0) return;
        before = skidimm_test::g_malloc_calls.load();  // from the 1024th row on
        rows_before = summary.rows;
      });
      const long allocations = skidimm_test::g_malloc_calls.load() - before;
      const long rows = summary.rows - rows_before;
      writer.commit();
      ASSERT_GT(rows, 10000);
      const double intervals = static_cast<double>(summary.timeline.intervals().size());
      EXPECT_LE(allocations, static_cast<long>(std::log2(intervals)) + 1)
          << allocations << " allocations in " << rows << " rows (" << intervals << " timeline intervals)";
    }
  }
}

}  // namespace
}  // namespace skidimm
