// The validation's power to catch a broken element, at the library: the test builds the broken
// case itself (scripts/mutants.sh breaks the sources and runs the whole `geardyn validate`).
#include "geardyn/validation.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <memory>

#include "geardyn/one_degree_run.hpp"
#include "geardyn/run.hpp"
#include "geardyn/train_case.hpp"
#include "geardyn/train_run.hpp"

namespace geardyn {
namespace {

// The train_pair check's tolerance: the exact engine's promise over a run, in b.
constexpr double kCheckToleranceB = 1e-8;

// The largest |(d - e)/b| difference over the samples between the train's first mesh and the
// one-degree model's own run of the same pair (the train_pair check's reference); infinite when
// the train's run fails or samples other times.
double worst_against_reference(const Case& as_train, const RunResult& reference) {
  const TrainRunResult r = run_train(as_train);
  if (!r.ok() || r.samples.t_s.size() != reference.samples.size()) return INFINITY;
  double worst = 0;
  for (std::size_t i = 0; i < reference.samples.size(); ++i)
    worst =
        std::max(worst, std::abs(r.samples.deflection_bar[i][0] - reference.samples.delta_bar[i]));
  return worst;
}

TEST(Validation, AMeshDampingOfTheWrongSignIsCaughtByTheOneDegreeReference) {
  // The paper's pair as a train, its mesh damping ratio negated on the case itself (the reader
  // refuses a negative ratio; the assembly takes the case as given): against the one-degree
  // model's run of the sound pair, the sound train agrees to the check's tolerance and the
  // broken one is caught by orders of magnitude beyond it.
  const RunResult reference = run_one_degree_model(park2010_pair_case());
  ASSERT_TRUE(reference.integration.ok()) << reference.integration.message;
  const Case sound = park2010_pair_as_train();
  auto train = std::make_shared<TrainCase>(*sound.train);
  ASSERT_GT(train->meshes.at(0).damping_ratio, 0);
  train->meshes.at(0).damping_ratio = -train->meshes.at(0).damping_ratio;
  Case broken = sound;
  broken.train = train;
  EXPECT_LT(worst_against_reference(sound, reference), kCheckToleranceB);
  EXPECT_GT(worst_against_reference(broken, reference), 1e4 * kCheckToleranceB);
}

}  // namespace
}  // namespace geardyn
