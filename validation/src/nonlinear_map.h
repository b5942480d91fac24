#pragma once
// Internal to validation/: the nonlinear map's rows (nonlinear_map.cc makes them from the plane
// and free-body studies' runs), its limits and its report (nonlinear_report.cc).
#include <validation/nonlinear_validation.h>

#include <cmath>
#include <map>
#include <ostream>
#include <string>
#include <vector>

namespace irdm::validation::nonlinear
{
  /// One method's run of one case of one material, against one truth (a row of nonlinear.csv).
  /// Errors are relative: L2 over the history (force, displacement, deformation), the total's
  /// (impulse); NaN where the family has no such measure. Grounded cases: over the whole run,
  /// displacement of the surface (the body does not move, so it is its deformation). Free
  /// cases: over the first contact, deformation in the best-fit frame (the rigid motion apart).
  struct MapRow
  {
    std::string c, material, method;
    double      force_error = NAN, impulse_error = NAN, displacement_error = NAN,
           deformation_error = NAN;
    double largest_strain  = NAN; // the P1 truth's, max_i |lambda_i - 1| over the window
    double us_per_step     = NAN; // the method's own cost per step of tau (FEM laws included)
    double fem_ms_per_step = NAN; // the P1 truth's cost per step of tau
    bool   stable          = true;
    // The scene family (press_top, press_side, press_between, impact_side, free_impact,
    // free_drop), its dimensionless load, and the truth the errors are against
    // (fem_neo_hookean_p1; fem_neo_hookean_p2, P2 on the same mesh; fem_neo_hookean_p1_<mesh>,
    // a finer mesh's).
    std::string family;
    double      load = NAN;
    std::string truth;

    /// The shape error the map draws: the displacement (grounded), else the deformation.
    double
    shape_error() const
    {
      return std::isnan(displacement_error) ? deformation_error : displacement_error;
    }
  };

  inline constexpr const char *p1_truth = "fem_neo_hookean_p1";
  inline constexpr const char *p2_truth = "fem_neo_hookean_p2"; // the same mesh's

  /// How far a truth is from the converged body: 0 the P1 truth, 1 a higher degree on the same
  /// mesh (fem_neo_hookean_p<d>), 2 another mesh (fem_neo_hookean_p<d>_<mesh>). Each case is
  /// mapped against its highest.
  int
  truth_rank(const std::string &truth);

  /// The two scene families of a run, as --families names them.
  bool
  in_planes(const std::string &family);

  /// Of an earlier run's rows, those a run that made `made` of `families` keeps: the rows of
  /// the families it did not run; with keep_rows also those of every case and material it did
  /// not make.
  std::vector<MapRow>
  rows_kept(const std::vector<MapRow> &earlier, const std::vector<MapRow> &made,
            const std::vector<std::string> &families, bool keep_rows);

  /// Every row of the plane family's sweeps against the P1 truth, and against the converged
  /// truth on the cases where it ran (nonlinear_map.cc).
  std::vector<MapRow>
  run_plane_family(const NonlinearMapOptions &o, std::ostream &log);

  /// The free study's options for the map's free family, checked (the scene read, the
  /// materials against the step divisions, the converged cases among the sweeps): InputError
  /// before any work.
  FreeBodyValidationOptions
  free_family_options(const NonlinearMapOptions &o);

  /// The same for the free family, every material.
  std::vector<MapRow>
  run_free_family(const NonlinearMapOptions &o, std::ostream &log);

  /// Where one method's error passes a threshold as the load grows, on one family and truth.
  struct Limit
  {
    std::string family, material, method, truth, measure;
    unsigned    points = 0;
    double      first_load = 0, last_load = 0;
    // The load where the error first passes 5 % and 10 %: linear in log(load) between the
    // last point within and the first past; below: the first point is already past; beyond:
    // no point is.
    double limit5 = NAN, limit10 = NAN;
    bool   below5 = false, below10 = false, beyond5 = false, beyond10 = false;
  };

  /// The load at which a history of (load, error) first passes `threshold` (sorted by load).
  /// Returns NAN with below or beyond set when it is not inside the sweep.
  double
  passing_load(const std::vector<std::pair<double, double>> &points, double threshold, bool &below,
               bool &beyond);

  /// Every family, material, method and measure of `rows` against the truth `truth` where each
  /// of that family's points is against it.
  std::vector<Limit>
  limits(const std::vector<MapRow> &rows, const std::string &truth);

  /// nonlinear.csv's columns, in order.
  std::string
  csv_header();

  std::string
  csv_line(const MapRow &r);

  /// Reads rows written by csv_line (IoError, InputError on a file not of this layout).
  std::vector<MapRow>
  read_rows(const std::string &file);

  /// nonlinear.csv (each case against its best truth), against_p1.csv (every row against the
  /// P1 truth) and limits.csv in dir, from every row (every truth).
  void
  write_csvs(const std::string &dir, const std::vector<MapRow> &rows);

  /// nonlinear.md (validation/templates/nonlinear.md), showing the charts present in dir;
  /// commands: each family's command line (family -> command).
  void
  write_markdown(const std::string &dir, const NonlinearMapOptions &o, const std::vector<MapRow> &rows,
                 const std::map<std::string, std::string> &commands);
} // namespace irdm::validation::nonlinear
