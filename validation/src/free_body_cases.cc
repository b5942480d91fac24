// The free-body study's cases (free_body_runs.h).
#include "free_body_runs.h"

#include <algorithm>
#include <cmath>

namespace irdm::validation::free_body
{
  namespace
  {
    /// The impact study: the upright cat 1 mm above the floor, moving toward it at `speed`,
    /// gravity off. Linear elasticity with a linear penalty is positively homogeneous: its
    /// response scales with the speed, so a linear method's relative error against it does
    /// not change with the speed, while linear against nonlinear elasticity shrinks with it.
    Case
    impact_case(const double speed)
    {
      std::ostringstream name;
      name << "impact_" << speed;
      Case c{name.str(), Eigen::Vector3d::UnitZ(), 0.001, Eigen::Vector3d(0, 0, -speed)};
      c.gravity      = false;
      c.duration     = 0.3;
      c.impact_speed = speed;
      return c;
    }

    std::vector<Case>
    cases(const bool quick)
    {
      const Eigen::Vector3d tilted =
        Eigen::AngleAxisd(25 * M_PI / 180, Eigen::Vector3d::UnitY()) * Eigen::Vector3d::UnitZ();
      std::vector<Case> c;
      if (!quick)
        c.push_back({"drop_2cm", Eigen::Vector3d::UnitZ(), 0.02});
      c.push_back({"drop_5cm", Eigen::Vector3d::UnitZ(), 0.05});
      if (!quick)
        {
          c.push_back({"drop_10cm", Eigen::Vector3d::UnitZ(), 0.10});
          c.push_back(rolling_case());
          c.push_back({"wall_throw", Eigen::Vector3d::UnitZ(), 0.005, Eigen::Vector3d(0.6, 0, 0),
                       Eigen::Vector3d::Zero(), true});
        }
      c.push_back({"tilted_5cm", tilted, 0.05});
      if (!quick)
        {
          // Resting 1 mm above the floor, pushed back and down at the head for 0.2 s: the
          // probe drives the rigid body and the deformation.
          Case poke{"probe_push", Eigen::Vector3d::UnitZ(), 0.001};
          poke.probe_force   = Eigen::Vector3d(-3, 0, -2);
          poke.probe_seconds = 0.2;
          c.push_back(poke);
        }
      return c;
    }
  } // namespace

  Case
  rolling_case()
  {
    return {"spin_roll", Eigen::Vector3d::UnitZ(), 0.02, Eigen::Vector3d::Zero(),
            Eigen::Vector3d(0, 8, 0), false, 2.0};
  }

  bool
  runs_impact_study(const FreeBodyValidationOptions &o)
  {
    return !o.impact_speeds.empty() &&
           (std::find(o.only_cases.begin(), o.only_cases.end(), "impact") != o.only_cases.end() ||
            (o.only_cases.empty() && !o.quick));
  }

  std::vector<Case>
  chosen_cases(const FreeBodyValidationOptions &o)
  {
    std::vector<Case> chosen;
    for (const Case &k : cases(o.quick && o.only_cases.empty()))
      if (o.only_cases.empty() ||
          std::find(o.only_cases.begin(), o.only_cases.end(), k.name) != o.only_cases.end())
        chosen.push_back(k);
    if (runs_impact_study(o))
      for (const double v : o.impact_speeds)
        chosen.push_back(impact_case(v));
    return chosen;
  }

  std::string
  material_name(const double E)
  {
    std::ostringstream s;
    s << E / 1000 << "kPa";
    return s.str();
  }

  double
  angle_deg(const Eigen::Matrix3d &R)
  {
    return Eigen::AngleAxisd(R).angle() * 180 / M_PI;
  }
} // namespace irdm::validation::free_body
