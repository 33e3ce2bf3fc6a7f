#include "identify/contact_law.hpp"

#include <cstdio>
#include <memory>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "plugin/registry.hpp"

namespace kneesim::identify {
namespace {

using ::testing::HasSubstr;

// A built-in law, F = k * x^2, with a deliberately wrong derivative when `wrong` is set.
bool wrong = false;
int square(const double* p, const kneesim_inputs* in, double* f, double* df, char* err, int len) {
  const double* x = nullptr;
  for (int c = 0; c < in->n_channels; ++c)
    if (std::string(in->names[c]) == "x") x = in->values[c];
  for (int i = 0; i < in->n_frames; ++i) {
    f[i] = p[0] * x[i] * x[i];
    if (df) df[i] = wrong ? x[i] : x[i] * x[i];
  }
  return 0;
}
const kneesim_param kParams[] = {{"k", "N", 0, 10, 1, 1, 0, "gain"}};
const char* const kInputs[] = {"x"};
const kneesim_contact_law kSquare = {sizeof(kneesim_contact_law), "square", "k x^2", 1, kParams, 1, kInputs,
                                     square, 0, nullptr, nullptr, nullptr};

TEST(ContactLaw, WrapsTheTable) {
  const ContactLaw law(kSquare);
  EXPECT_EQ(law.getName(), "square");
  EXPECT_EQ(law.getOrigin(), "built-in");
  EXPECT_EQ(law.getNumParameters(), 1);
  EXPECT_EQ(law.findParameterIndex("k"), 0);
  EXPECT_EQ(law.findParameterIndex("q"), -1);
  try {
    law.getParameterIndex("q", {"s.xml", 2, "free"});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "s.xml:2: free: contact law 'square' has no parameter 'q' (parameters: k)");
  }
  EXPECT_EQ(law.getDefaultValues()[0], 1.0);
  EXPECT_EQ(law.calcDerived(Eigen::VectorXd::Ones(1)).size(), 0);
}

TEST(ContactLaw, ForcesJacobianAndInputsSurviveCopies) {
  const ContactLaw law(kSquare);
  const std::vector<double> time{0, 1, 2};
  const ChannelMap ch{{"x", {1, 2, 3}}};
  LawInputs in(law, ch, time, "t");
  const LawInputs copy = in;  // pointers must follow the copy
  in = LawInputs(law, ch, time, "u");  // reassigning the original leaves the copy intact
  Eigen::VectorXd f;
  Eigen::MatrixXd j;
  law.calcForce(Eigen::VectorXd::Constant(1, 2.0), copy, f, &j);
  EXPECT_EQ(f, Eigen::Vector3d(2, 8, 18));
  EXPECT_EQ(j.col(0), Eigen::Vector3d(1, 4, 9));
  EXPECT_EQ(copy.getTrialName(), "t");
  EXPECT_EQ(copy.get().n_channels, 2);  // time and x
  EXPECT_STREQ(copy.get().names[0], "time");
}

TEST(ContactLaw, DerivativeCheckCatchesAWrongJacobian) {
  const ContactLaw law(kSquare);
  const std::vector<double> time{0, 1, 2};
  const ChannelMap ch{{"x", {1, 2, 3}}};
  const LawInputs in(law, ch, time, "t");
  wrong = false;
  EXPECT_LT(calcDerivativeError(law, Eigen::VectorXd::Constant(1, 2.0), in)[0], 1e-8);
  wrong = true;
  EXPECT_GT(calcDerivativeError(law, Eigen::VectorXd::Constant(1, 2.0), in)[0], 0.5);
  wrong = false;
}

TEST(ContactLaw, ChannelLengthsAreChecked) {
  const ContactLaw law(kSquare);
  const std::vector<double> time{0, 1, 2};
  const ChannelMap ch{{"x", {1, 2}}};
  try {
    LawInputs in(law, ch, time, "walk", {"a.xml", 1, "Trial"});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "a.xml:1: Trial: trial 'walk': channel 'x': expected 3 values (one per time frame), got 2");
  }
}

// A law computed in C++ (how gap/ wraps a baseline law with effects): F = k * x^3, with the
// table's calc_force left NULL so only the implementation can answer.
class CubeLaw : public LawImplementation {
 public:
  CubeLaw() : table_{sizeof(kneesim_contact_law), "cube", "k x^3", 1, kParams, 1, kInputs, nullptr,
                     0, nullptr, nullptr, nullptr} {}
  const kneesim_contact_law& getTable() const override { return table_; }
  int calcForce(const double* p, const kneesim_inputs& in, double* f, double* df, char* err,
                int len) const override {
    const double* x = in.values[1];  // channel 0 is time
    for (int i = 0; i < in.n_frames; ++i) {
      if (x[i] < 0) {
        std::snprintf(err, len, "negative x at frame %d", i);
        return 1;
      }
      f[i] = p[0] * x[i] * x[i] * x[i];
      if (df) df[i] = x[i] * x[i] * x[i];
    }
    return 0;
  }

 private:
  kneesim_contact_law table_;
};

TEST(ContactLaw, ImplementationInCppIsCalledAndKeptAlive) {
  std::unique_ptr<ContactLaw> copy;
  {
    const ContactLaw law(std::make_shared<const CubeLaw>(), "gap");
    copy = std::make_unique<ContactLaw>(law);  // the copy shares ownership of the implementation
  }
  EXPECT_EQ(copy->getName(), "cube");
  EXPECT_EQ(copy->getOrigin(), "gap");
  const std::vector<double> time{0, 1, 2};
  const ChannelMap ch{{"x", {1, 2, 3}}};
  const LawInputs in(*copy, ch, time, "t");
  Eigen::VectorXd f;
  Eigen::MatrixXd j;
  copy->calcForce(Eigen::VectorXd::Constant(1, 2.0), in, f, &j);
  EXPECT_EQ(f, Eigen::Vector3d(2, 16, 54));
  EXPECT_EQ(j.col(0), Eigen::Vector3d(1, 8, 27));
  EXPECT_LT(calcDerivativeError(*copy, Eigen::VectorXd::Constant(1, 2.0), in)[0], 1e-7);
  const ChannelMap bad{{"x", {1, -2, 3}}};
  const LawInputs in_bad(*copy, bad, time, "walk");
  try {
    copy->calcForce(Eigen::VectorXd::Constant(1, 2.0), in_bad, f);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "contact law 'cube' failed on trial 'walk': negative x at frame 1");
  }
}

TEST(ContactLaw, PluginLawFromTheRegistry) {
  plugin::Registry r;
  r.loadPlugin("hertz");
  const ContactLaw law = ContactLaw::fromRegistry(r, "hertz");
  EXPECT_THAT(law.getOrigin(), HasSubstr("libkneesim_hertz.so"));
  EXPECT_THROW(ContactLaw::fromRegistry(r, "hertzz"), InputError);
  EXPECT_EQ(law.getDerivedUnits(), (std::vector<std::string>{"Pa", "Pa/m"}));
  // K = E / (1 - nu^2) by hand: 1e9 / 0.75 at nu = 0.5.
  EXPECT_NEAR(law.calcDerived(Eigen::Vector3d(1e9, 0.5, 0.04))[0], 1e9 / 0.75, 1e-3);
}

}  // namespace
}  // namespace kneesim::identify
