#include "skidimm/engine/input_envelope.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>

#include "core/test_banks.h"

namespace skidimm {
namespace {

using skidimm_test::BankBuilder;
using skidimm_test::ScalarLinearModel;
using skidimm_test::vec;

Bank two_modes() {
  BankBuilder b;
  b.models = {std::make_shared<ScalarLinearModel>(-1.0, 1.0), std::make_shared<ScalarLinearModel>(-2.0, 0.5)};
  b.q = {Eigen::MatrixXd::Constant(1, 1, 0.01)};
  b.r = Eigen::MatrixXd::Constant(1, 1, 0.25);
  b.x0 = vec({1.0});
  return b.build();
}

// The envelope of a class spans its modes' ranges; an input a mode has no
// range for is unbounded for its class.
TEST(InputEnvelope, AClassSpansItsModesAndAMissingRangeIsUnbounded) {
  Bank bank = two_modes();
  bank.config.classes = {{"both", {0, 1}}};
  bank.config.modes[0].fitted_inputs["u"] = {0.5, 1.5};
  bank.config.modes[1].fitted_inputs["u"] = {2.0, 3.0};
  const InputEnvelope spanned(bank.config);
  EXPECT_EQ(spanned.num_classes(), 1);
  EXPECT_EQ(spanned.outside(0, vec({1.75})).input, -1) << "between the modes' ranges, inside the class's";
  const Excursion above = spanned.outside(0, vec({3.5}));
  EXPECT_EQ(above.input, 0);
  EXPECT_DOUBLE_EQ(above.beyond, 0.2) << "0.5 beyond a range 2.5 wide";
  EXPECT_EQ(spanned.describe(0, above), "u 3.5 (both fitted on 0.5 to 3)");
  EXPECT_EQ(spanned.outside(0, vec({std::nan("")})).input, -1) << "a missing value is not outside";
  EXPECT_EQ(spanned.outside(0, vec({3.0 + 1e-12})).input, -1) << "round-off past the end is inside";
  EXPECT_EQ(spanned.outside(0, vec({0.5 - 1e-8})).input, -1) << "within 1e-7 of the end's magnitude";
  EXPECT_EQ(spanned.outside(0, vec({0.5 - 1e-6})).input, 0);
  bank.config.modes[1].fitted_inputs.clear();
  const InputEnvelope unbounded(bank.config);
  EXPECT_FALSE(unbounded.empty());
  EXPECT_EQ(unbounded.outside(0, vec({100.0})).input, -1);
}

// A class fitted at one value of an input has seen nothing of any other.
TEST(InputEnvelope, ARangeOfOneValueMakesEveryOtherInfinitelyFarOut) {
  Bank bank = two_modes();
  bank.config.modes[0].fitted_inputs["u"] = {0.5, 0.5};
  const InputEnvelope envelope(bank.config);
  EXPECT_EQ(envelope.outside(0, vec({0.5})).input, -1);
  EXPECT_EQ(envelope.outside(0, vec({0.51})).beyond, std::numeric_limits<double>::infinity());
  EXPECT_EQ(envelope.outside(1, vec({0.51})).input, -1) << "mode 1, its own class, has no range";
}

}  // namespace
}  // namespace skidimm
