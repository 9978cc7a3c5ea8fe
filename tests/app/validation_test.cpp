// The validation scenes of `graspsim validate`, in their quick form (release: a few
// seconds each). Each asserts the physical pass criterion of its case, and the figures
// behind it, so that a regression names what broke.
#include "app/validation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace gs::app {
namespace {

const ValidationResult* Find(const std::vector<ValidationResult>& v, const std::string& name) {
  for (const ValidationResult& r : v)
    if (r.name == name) return &r;
  return nullptr;
}

ValidationOptions Quick() {
  ValidationOptions o;
  o.quick = true;
  return o;
}

TEST(Validation, InclineSticksBelowAndSlidesAboveTheFrictionAngle) {
  const auto v = ValidateIncline(Quick());
  const ValidationResult* stick = Find(v, "incline_stick");
  const ValidationResult* slide = Find(v, "incline_slide");
  ASSERT_NE(stick, nullptr);
  ASSERT_NE(slide, nullptr);
  EXPECT_TRUE(stick->pass) << stick->detail;
  EXPECT_LT(stick->error, 1e-6) << stick->detail;   // m over 1 s
  EXPECT_TRUE(slide->pass) << slide->detail;
  EXPECT_LT(slide->error, 0.05) << slide->detail;   // relative error of the acceleration
}

TEST(Validation, HertzExponentAndContactRadius) {
  const auto v = ValidateHertz(Quick());
  const ValidationResult* exponent = Find(v, "hertz_exponent");
  const ValidationResult* radius = Find(v, "hertz_radius");
  ASSERT_NE(exponent, nullptr);
  ASSERT_NE(radius, nullptr);
  EXPECT_TRUE(exponent->pass) << exponent->detail;
  EXPECT_LT(exponent->error, 0.1) << exponent->detail;
  EXPECT_TRUE(radius->pass) << radius->detail;
  // measured 1.1% with the kernel truncated at the scene's influence radius; it was
  // 11% when the Boussinesq kernel was cut at 8 spacings, narrower than the 2 N patch
  EXPECT_LT(radius->error, 0.05) << radius->detail;
}

TEST(Validation, PinchHoldsJustAboveAndFallsJustBelowTheFrictionThreshold) {
#ifdef GRASPSIM_SANITIZED
  // skipped under sanitizers only (too slow there); the release suite runs it
  GTEST_SKIP() << "two 2.2 s simulations of a 8,000-point prism (about a minute or more under sanitizers); "
                  "the release build runs it, and ContactModel tests cover the mechanics under sanitizers";
#endif
  const auto v = ValidatePinch(Quick());
  const ValidationResult* hold = Find(v, "pinch_hold");
  const ValidationResult* fall = Find(v, "pinch_fall");
  ASSERT_NE(hold, nullptr);
  ASSERT_NE(fall, nullptr);
  EXPECT_TRUE(hold->pass) << hold->detail;
  EXPECT_LT(hold->error, 1e-6) << hold->detail;  // creep, m/s (it was 2e-4 before the lever-arm fix)
  EXPECT_TRUE(fall->pass) << fall->detail;
}

TEST(Validation, PaperGraspHoldsTheBox) {
#ifdef GRASPSIM_SANITIZED
  // skipped under sanitizers only (minutes there); the release suite runs it
  GTEST_SKIP() << "1,900 steps of the 36,000-point paper scene (minutes under sanitizers); the release build runs it";
#endif
  const auto v = ValidatePaperGrasp(Quick());
  const ValidationResult* grasp = Find(v, "paper_grasp");
  ASSERT_NE(grasp, nullptr);
  EXPECT_TRUE(grasp->pass) << grasp->detail;
  // the box sags about 1 mm into the fingertips when lifted, then stays
  EXPECT_LT(grasp->error, 0.003) << grasp->detail;
  EXPECT_NE(grasp->detail.find("0 at the sweep cap"), std::string::npos) << grasp->detail;
}

TEST(Validation, UnknownNameIsRefused) {
  std::vector<ValidationResult> out;
  EXPECT_FALSE(RunValidation("no-such-case", Quick(), &out));
  EXPECT_TRUE(out.empty());
}

TEST(Validation, StacksStandAtEveryMassRatioAtTheDefaultTolerance) {
  const auto v = ValidateStack(Quick());
  // quick: mass ratios 1 and 10 (100 and 1,000 take minutes: the full run)
  for (const char* name : {"stack_ratio_1", "stack_ratio_10"}) {
    const ValidationResult* r = Find(v, name);
    ASSERT_NE(r, nullptr) << name;
    EXPECT_TRUE(r->pass) << r->detail;
    EXPECT_LE(r->error, 1e-6) << r->detail;  // walk, m/s
  }
}

TEST(Validation, EveryMassTimesKLeavesTheStackUnchanged) {
  const auto v = ValidateScale(Quick());
  for (const char* name : {"scale_x8", "scale_x1024", "scale_x10", "scale_x1000", "scale_x8_sweeps",
                           "scale_x1024_sweeps", "scale_x10_sweeps", "scale_x1000_sweeps"}) {
    const ValidationResult* r = Find(v, name);
    ASSERT_NE(r, nullptr) << name;
    EXPECT_TRUE(r->pass) << r->detail;
  }
}

}  // namespace
}  // namespace gs::app
