#pragma once
// A cubature for a reduced nonlinear model (issue 50; docs/reduced-model.md): a few elements
// with non-negative weights whose weighted reduced forces match every element's sum on
// training states (An, Kim and James 2008; Farhat's ECSW). Greedy: the element whose reduced
// force best matches the residual is added, then every weight is refit by non-negative least
// squares (Lawson and Hanson), until the relative residual is within the tolerance. Each
// training state's force is scaled to unit norm, so that small and large deformations count
// alike.
#include <irdm/reduced_nonlinear.h>

#include <Eigen/Dense>

#include <array>
#include <functional>
#include <string>
#include <vector>

namespace irdm
{
  /// min ||A x - b|| over x >= 0 (Lawson and Hanson 1974, chapter 23).
  Eigen::VectorXd
  non_negative_least_squares(const Eigen::MatrixXd &A, const Eigen::VectorXd &b);

  /// Training presses: rigid planes from directions drawn at random (fixed seed), each moved
  /// into the body from its outermost free point to a depth drawn between 0.2 and 1 times
  /// max_depth over ramp_steps and held for as many, the state kept every `every` steps.
  struct TrainingOptions
  {
    unsigned presses    = 12;
    double   max_depth  = 0.02; // m
    unsigned ramp_steps = 40;
    unsigned every      = 4;
    unsigned seed       = 1;
    std::function<void(const std::string &)> log;
  };

  struct TrainingSet
  {
    std::vector<Eigen::VectorXd>       states;     // reduced coordinates q
    std::vector<std::array<double, 3>> directions; // of the presses (unit, into the body)
    std::vector<double>                supports;   // m, the outermost free point's d . x
    std::vector<double>                depths;     // m
    std::string   source = "reduced_model"; // what made the states ("reduced_model", "fem")
    unsigned long failed_steps = 0;         // steps the source could not solve
  };

  /// The presses alone (no states): the same draws whatever runs them.
  TrainingSet
  training_presses(const ReducedNonlinearModel &model, const TrainingOptions &options);

  /// The presses run on the every-element reduced model itself.
  TrainingSet
  training_states(const ReducedNonlinearModel &every_element, const TrainingOptions &options);

  struct CubatureOptions
  {
    double   tolerance    = 0.01; // relative residual of the training forces
    unsigned max_elements = 1000;
    std::function<void(const std::string &)> log;
  };

  struct Cubature
  {
    std::vector<unsigned> elements;
    std::vector<double>   weights;
    double                training_error = 0; // relative residual reached
    unsigned              n_states       = 0;
    double                seconds        = 0;
  };

  /// InputError if the model already has a cubature or no state is given.
  Cubature
  train_cubature(const ReducedNonlinearModel &every_element,
                 const std::vector<Eigen::VectorXd> &states, const CubatureOptions &options);

  /// Writes `source` (an every-element reduced model file) with the cubature added to
  /// `output` (atomically; output may not be source).
  void
  write_cubature_model(const std::string &source, const std::string &output, const Cubature &c,
                       const TrainingSet &training);
} // namespace irdm
